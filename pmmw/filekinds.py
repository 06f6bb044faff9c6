"""`pmmw validate FILE`: which kind of pmmw file a YAML file is, and its check as that kind.

pmmw reads five kinds of YAML file, told apart by the keys only that kind has:

=====================  ==============================  ===========================================
kind                   told by                         checked by
=====================  ==============================  ===========================================
scenario               anything else                   `pipeline.validate` (meshes, materials, sky)
sweep file             ``grid``                        `sweep_spec.load_sweep_file`, its scenario,
                                                       every variant against the scenario schema
physical-optics job    ``targets``                     `po.job.load_job`, its meshes and materials
brdf stack file        ``layers`` (no ``scene``)       `brdf.stack.load_stack`
Dask cluster file      ``kind`` of slurm, pbs, ...     its kind and required keys (``cores``,
                                                       ``memory``), without dask-jobqueue
=====================  ==============================  ===========================================

The result (a mapping, printed as YAML by the command) starts with ``kind``; a file that is
checked as a scenario and fails names the other kinds when it has one of their keys.
"""

from __future__ import annotations

import math
from pathlib import Path

from pmmw.errors import UserError, UserErrors, clear_warnings, collected_warnings
from pmmw.io.inputs import check_input_path
from pmmw.io.yamlio import read_yaml

SCENARIO, SWEEP, PO_JOB, STACK, CLUSTER = (
    "scenario",
    "sweep file",
    "physical-optics job",
    "brdf stack file",
    "Dask cluster file",
)
#: the keys that tell each kind apart (a scenario has none of them)
MARKS = {SWEEP: "grid", PO_JOB: "targets", STACK: "layers", CLUSTER: "kind"}


def file_kind(raw) -> str:
    """The kind of a YAML file's top-level mapping (`SCENARIO` when nothing else fits)."""
    from pmmw.distributed import CLUSTER_KINDS

    if not isinstance(raw, dict):
        return SCENARIO
    keys = set(map(str, raw))
    scenario_keys = {"imager", "scene"}
    if "grid" in keys or ("scenario" in keys and not keys & scenario_keys):
        return SWEEP
    if "targets" in keys and not keys & scenario_keys:
        return PO_JOB
    if "layers" in keys and not keys & scenario_keys:
        return STACK
    if str(raw.get("kind", "")).lower() in CLUSTER_KINDS and not keys & scenario_keys:
        return CLUSTER
    return SCENARIO


def validate_file(path, overrides=(), preview=None) -> dict:
    """Check ``path`` as the kind of pmmw file it is; what ``pmmw validate`` prints.

    Parameters
    ----------
    path : str or Path
        A scenario, sweep file, physical-optics job, brdf stack file or Dask cluster file.
    overrides : list of str
        ``key.path=value`` items (``--set``): for a scenario, and for a sweep file's scenario.
    preview : str or Path, optional
        For a scenario (or a sweep file's scenario): a PNG of the view with its regions
        outlined and named (`pipeline.view_preview`).

    Returns
    -------
    dict
        ``kind`` first, then what that kind resolves to.

    Raises
    ------
    UserError or UserErrors
        Every problem, by file and key.
    """
    path = Path(path)
    check_input_path(path)
    if not path.is_file():
        raise UserError("file not found" if not path.exists() else "is not a file", path)
    # a Blender file is a scenario (exported by the add-on, `pmmw.blender`); everything else is YAML
    raw = None if path.suffix.lower() == ".blend" else read_yaml(path, "pmmw file")
    kind = file_kind(raw)
    if kind not in (SCENARIO, SWEEP) and preview is not None:
        raise UserError(f"--preview draws a scenario's view; {path.name} is a {kind}", "--preview")
    if kind != SCENARIO and overrides:
        raise UserError(f"--set overrides a scenario's keys; {path.name} is a {kind}", "--set")
    if kind == SWEEP:
        return _sweep(path, preview)
    if kind == PO_JOB:
        return _po_job(path)
    if kind == STACK:
        return _stack(path)
    if kind == CLUSTER:
        return _cluster(path, raw)
    from pmmw.pipeline import validate

    try:
        return {"kind": SCENARIO, **validate(path, list(overrides), preview=preview)}
    except UserError as exc:
        other = [k for k, mark in MARKS.items() if isinstance(raw, dict) and mark in raw]
        if not other:
            raise
        hint = UserError(
            f"checked as a scenario; a {other[0]} has `{MARKS[other[0]]}:` and no imager or scene key", path
        )
        raise UserErrors([*getattr(exc, "errors", [exc]), hint]) from None


def _sweep(path: Path, preview=None) -> dict:
    from pmmw.pipeline import validate, variant_check
    from pmmw.sweeps.spec import check_variants, load_sweep_file, zipped_keys

    spec = load_sweep_file(path)
    if not spec.scenario.is_file():
        raise UserError(f"scenario file not found: {spec.scenario}", path, "scenario")
    count = check_variants(spec, variant_check())
    base = validate(spec.scenario, preview=preview)
    _check_variant_regions(spec)
    base["warnings"] = collected_warnings()
    return {
        "kind": SWEEP,
        "scenario": str(spec.scenario),
        "variants": count,
        "grid": {k: list(v) for k, v in spec.grid},
        "zipped": zipped_keys(spec),
        "executor": spec.executor,
        **({"cluster": str(spec.cluster)} if spec.cluster else {}),
        "out": str(spec.out or Path.cwd() / "out" / f"{spec.scenario.stem}_sweep"),
        "scenario_check": {"geometry": base["geometry"], "warnings": base.get("warnings", [])},
    }


def _check_variant_regions(spec) -> None:
    """Every variant's regions in its view (`pipeline.check_regions`): a region out of view in
    some variants is one warning per region naming them (their contrasts with it would be NaN),
    not an error, since the other variants still compare it."""
    from pmmw.config import load_scenario
    from pmmw.errors import warn
    from pmmw.pipeline import check_regions
    from pmmw.sweeps.spec import overrides_of, variants

    out_of_view: dict[str, list[str]] = {}
    for i, params in enumerate(variants(spec)):
        scn = load_scenario(spec.scenario, overrides_of(params))
        if not scn.output.regions:
            continue
        try:
            check_regions(scn)
        except UserError as exc:
            for e in getattr(exc, "errors", [exc]):
                out_of_view.setdefault(str(e.key), []).append(f"v{i:03d}")
    for key, names in out_of_view.items():
        warn(
            f"{spec.source}: {key} is behind the imager or outside the image in variant(s) {', '.join(names)}: "
            "their contrasts with it will be NaN (pmmw validate with those values names the pixels)"
        )


def _po_job(path: Path) -> dict:
    from pmmw.physical_optics.job import load_job
    from pmmw.pipeline import check_material_ids
    from pmmw.scene.geometry import build_geometry
    from pmmw.scene.materials import MaterialDB

    clear_warnings()
    job = load_job(path)
    db = MaterialDB.load().with_overrides(dict(job.materials), file=job.source_file)
    check_material_ids(job.targets, db, job.source_file)
    geom = build_geometry(job.targets, scenario_file=job.source_file)
    return {
        "kind": PO_JOB,
        "name": job.name,
        "frequencies_GHz": [f / 1e9 for f in job.frequencies],
        "polarization": list(job.polarization),
        "monostatic": job.monostatic,
        **(
            {"incidence_deg": [round(math.degrees(float(a)), 6) for a in job.incidence]}
            if job.incidence is not None
            else {}
        ),
        "observation": {"theta": job.observation.theta, "phi": job.observation.phi},
        "targets": {name: {"triangles": int((geom.face_object == i).sum())} for i, name in enumerate(geom.objects)},
        "bounces": job.bounces,
        "warnings": collected_warnings(),
    }


def _stack(path: Path) -> dict:
    from pmmw.reflectance.stack import load_stack

    clear_warnings()
    stack = load_stack(path)
    layers = []
    for layer in stack.layers:
        layers.append(
            {
                **({"metal": True} if layer.metal else {"eps": [float(layer.eps.real), float(layer.eps.imag)]}),
                **({"thickness_m": layer.thickness} if layer.thickness is not None else {}),
                **({"roughness": repr(layer.roughness)} if layer.roughness is not None else {}),
                **({"coating_films": len(layer.coating)} if layer.coating else {}),
            }
        )
    return {
        "kind": STACK,
        **({"frequency_Hz": stack.frequency} if stack.frequency is not None else {}),
        "ambient_eps": [float(stack.ambient_eps.real), float(stack.ambient_eps.imag)],
        "layers": layers,
        "warnings": collected_warnings(),
    }


def _cluster(path: Path, raw: dict) -> dict:
    from pmmw.distributed import CLUSTER_KINDS

    errors = [UserError("required key missing", path, k) for k in ("cores", "memory") if k not in raw]
    for k in ("cores", "jobs"):
        if k in raw and not (isinstance(raw[k], int) and not isinstance(raw[k], bool) and raw[k] >= 1):
            errors.append(UserError(f"expected a whole number >= 1, got {raw[k]!r}", path, k))
    if errors:
        raise UserErrors(errors) if len(errors) > 1 else errors[0]
    kind = str(raw["kind"]).lower()
    return {
        "kind": CLUSTER,
        "cluster": f"dask_jobqueue.{CLUSTER_KINDS[kind]}",
        **{str(k): v for k, v in raw.items() if k != "kind"},
    }
