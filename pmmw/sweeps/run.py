"""`pmmw sweep`: a grid of renders of one scenario, a results table and a trade-study report.

A sweep varies scenario keys (``--grid KEY=LIST``, each list a YAML list or
``linspace(START, STOP, N)`` with an optional unit): every combination, or with ``zip`` the lists
side by side (a flight path of poses). Each variant is an ordinary render (`pipeline.render`)
into ``DIR/<variant>/``; ``DIR/sweep.csv`` has one row per variant: ``variant``, one column per
grid key, ``status``, ``exr``, ``wall_s``, then every region's mean and every pairwise contrast
in K and in noise sigmas from the variant's report, and per contrast its ``snr`` and
``detectable`` by the one detection criterion (`imaging.detection`) in the channel the report
leads with (``snr beacon - runway Ey2``), the SNR's Monte Carlo standard error (``snr_stderr``)
and the probability of detection at the scenario's ``output.false_alarm`` (``pd``), and whether every
material is inside its stated range at the variant's frequency (``inside stated ranges``; the
materials that are not in ``outside stated range``: `pipeline.materials_band`).
``DIR/report.md`` adds plots of the SNRs against the swept values with the criterion's threshold,
which variants are detectable, the detection limit along the first numeric axis (the largest range,
or smallest aperture, ... at which each contrast is still detected, with its uncertainty:
`imaging.detection.detection_limit`), and a contact sheet of the previews.

Executors: ``local`` renders the variants one after another, each on all cores (variants and
tiles share the machine without oversubscribing it); ``dask`` sends each variant to a Dask
cluster as one task (rendered in the worker's process): a ``LocalCluster`` when no address is
given, a running scheduler (``--scheduler tcp://host:8786``), or a batch-queue cluster from
dask-jobqueue (``--cluster slurm.yaml``). The same seeds give bit-identical images everywhere.
A Dask task renders its variant in a temporary folder of its worker and returns the files; pmmw
writes them into ``DIR/<variant>/`` (`_commit_variant`). So a task still running after its sweep
ended (its scheduler killed, pmmw stopped: a worker finishes the task it has begun) never writes
into ``DIR``. A scheduler that goes away stops the sweep with one line and status 1, after
``sweep.csv`` and the report of the variants done.

A variant is done when its folder holds ``variant.json`` with the hash of the scenario it renders
(`pipeline.scenario_hash`); ``--resume`` skips those. A failed variant is recorded with its error
and the others go on; the sweep then exits non-zero.
"""

from __future__ import annotations

import csv
import io
import json
import tempfile
import time
from pathlib import Path

from pmmw.distributed import EXECUTORS
from pmmw.errors import EnvironmentProblem, UserError, exception_text
from pmmw.io.atomic import write_text_atomic
from pmmw.io.lock import output_lock
from pmmw.io.progress import StatusLine, say
from pmmw.scene.materials import FREQ_REL_TOL
from pmmw.sweeps.spec import (  # noqa: F401
    MAX_VARIANTS,
    SweepSpec,
    _label,
    _yaml_value,
    check_variants,
    grid_values,
    linspace,
    load_sweep_file,
    overrides_of,
    parse_grid_options,
    variant_steps,
    variants,
    zipped_keys,
)


def render_variant(
    scenario: str, overrides: list[str], out_dir: str, workers: int | None, shash: str, ship: bool = False
) -> dict:
    """Render one variant (a Dask task or a local call); never raises for a user error: the
    outcome is in ``status``.

    With ``ship`` (a Dask task) the variant is rendered in a temporary folder of the worker,
    deleted after, and the row also holds its files (``files``: path relative to the variant's
    folder -> bytes; ``exr`` relative too) and that folder (``rendered_in``), for the client to
    write into ``out_dir`` (`_commit_variant`). Nothing is written into ``out_dir`` then.
    """
    if ship:
        return _render_shipped(scenario, overrides, workers)
    row = _render_row(scenario, overrides, Path(out_dir), workers)
    if row["status"] == "done":
        write_text_atomic(Path(out_dir) / "variant.json", json.dumps({"hash": shash, "overrides": overrides}, indent=1))
    return row


def _scratch_folder() -> str | None:
    """The Dask worker's own folder (``local_directory``) when this runs in one, else None (the
    system's temporary folder)."""
    try:
        from distributed import get_worker

        return get_worker().local_directory
    except (ImportError, ValueError, AttributeError):  # not in a worker
        return None


def _render_shipped(scenario: str, overrides: list[str], workers: int | None) -> dict:
    """`render_variant` with ``ship``: the render in a temporary folder, its files in the row."""
    with tempfile.TemporaryDirectory(prefix="pmmw-variant-", dir=_scratch_folder(), ignore_cleanup_errors=True) as tmp:
        out = Path(tmp) / "out"
        row = _render_row(scenario, overrides, out, workers)
        if row["status"] == "done":
            try:
                row["files"] = {
                    p.relative_to(out).as_posix(): p.read_bytes()
                    for p in sorted(out.rglob("*"))
                    if p.is_file() and not any(part.startswith(".") for part in p.relative_to(out).parts)
                }
            except OSError as e:
                return {
                    "status": f"failed: reading the rendered files in {tmp}: {e}",
                    "exr": "",
                    "wall_s": row["wall_s"],
                }
            row["exr"] = Path(row["exr"]).relative_to(out).as_posix() if row["exr"] else ""
            row["rendered_in"] = str(out)
    return row


def _render_row(scenario: str, overrides: list[str], out: Path, workers: int | None) -> dict:
    """Render one variant into ``out``; its table row (``status``, ``exr``, ``wall_s``, ``rays``)."""
    from pmmw.errors import UserError as _UserError
    from pmmw.pipeline import render

    t0 = time.perf_counter()
    try:
        exrs = render(scenario, overrides, out=out, workers=workers, quiet=True)
    except _UserError as e:
        return {"status": f"failed: {e}", "exr": "", "wall_s": round(time.perf_counter() - t0, 3)}
    except Exception as e:  # noqa: BLE001 - a bug or the machine: recorded as text; an exception object
        # crossing Dask can hang its client when the traceback does not pickle
        return {
            "status": f"failed: {type(e).__name__}: {str(e)[:300]} ({exception_text(e, 600)})",
            "exr": "",
            "wall_s": round(time.perf_counter() - t0, 3),
        }
    rays = 0
    for path in out.glob("report*.json"):  # one report per frequency
        try:
            rays += int(json.loads(path.read_text()).get("rays", 0))
        except (OSError, ValueError, TypeError):
            pass
    return {
        "status": "done",
        "exr": str(exrs[0]) if exrs else "",
        "wall_s": round(time.perf_counter() - t0, 3),
        "rays": rays,
    }


def _variant_hash(scenario: Path, overrides: list[str]) -> str:
    """The variant's `scenario_hash` (its scenario, database and input files; no mesh is built)."""
    from pmmw.config import load_scenario
    from pmmw.pipeline import material_database, scenario_hash

    scn = load_scenario(scenario, overrides)
    return scenario_hash(scn, material_database(scn))


def _done(out_dir: Path, shash: str) -> bool:
    try:
        return json.loads((out_dir / "variant.json").read_text())["hash"] == shash and any(out_dir.glob("*.exr"))
    except (OSError, ValueError, KeyError):
        return False


def job_script(spec: SweepSpec) -> str:
    """The batch job script dask-jobqueue would submit for the sweep's ``cluster`` file
    (``pmmw sweep --dry-run``)."""
    if spec.cluster is None:
        raise UserError("--dry-run prints the batch job script of --cluster FILE", "--dry-run")
    from pmmw.distributed import jobqueue_cluster

    return jobqueue_cluster(spec.cluster).job_script()


def run_sweep(spec: SweepSpec, *, resume: bool = False, quiet: bool = False, dry_run: bool = False) -> int:
    """Render every variant, write ``sweep.csv`` and ``report.md``; returns the exit status
    (0 all done, 1 some failed)."""
    if spec.executor not in EXECUTORS:
        raise UserError(f"expected one of {', '.join(EXECUTORS)}, got {spec.executor!r}", "--executor")
    if spec.executor == "dask" and spec.scheduler and spec.cluster is None and not dry_run:
        from pmmw.distributed import probe_scheduler

        probe_scheduler(spec.scheduler)  # a wrong address told before any variant is looked at
    if dry_run:
        say(job_script(spec))
        return 0
    if not spec.scenario.is_file():
        raise UserError("scenario file not found", spec.scenario)
    from pmmw.pipeline import variant_check

    # every swept key and value against the schema, and the material ids, before anything is written
    check_variants(spec, variant_check())
    from pmmw.filekinds import _check_variant_regions

    _check_variant_regions(spec)  # a region out of some variants' view: one warning before they render
    out = (spec.out or Path.cwd() / "out" / f"{spec.scenario.stem}_sweep").resolve()
    with output_lock(out):  # one sweep per folder: a second is refused, naming this one
        return _sweep_into(spec, out, resume=resume, quiet=quiet)


def _sweep_into(spec: SweepSpec, out: Path, *, resume: bool, quiet: bool) -> int:
    """`run_sweep` in the locked output folder ``out``."""
    steps = variant_steps(spec)
    combos = variants(spec, steps)
    names = [f"v{i:03d}" for i in range(len(combos))]
    plans, rows = [], {}
    for name, params in zip(names, combos):
        overrides = overrides_of(params)
        try:
            shash = _variant_hash(spec.scenario, overrides)
        except UserError as e:
            rows[name] = {"status": f"failed: {e}", "exr": "", "wall_s": 0.0}
            continue
        vdir = out / name
        if resume and _done(vdir, shash):
            rows[name] = {"status": "done", "exr": str(next(vdir.glob("*.exr"))), "wall_s": 0.0}
            continue
        plans.append((name, overrides, vdir, shash))
    log = _Log(len(combos), quiet)
    log.update(rows)
    if spec.executor == "local":
        for name, overrides, vdir, shash in plans:
            rows[name] = render_variant(str(spec.scenario), overrides, str(vdir), spec.workers, shash)
            log.update(rows)
    lost = None  # the address of a Dask scheduler that went away
    if spec.executor == "dask" and plans:
        lost = _render_on_dask(spec, plans, rows, log)
    table = [_row(spec, out, name, step, rows[name]) for name, step in zip(names, steps)]
    write_table(out / "sweep.csv", table)
    from pmmw.sweeps.report import write_report

    write_report(out, spec, table)
    if lost:
        done = sum(r["status"] == "done" for r in table)
        raise EnvironmentProblem(
            f"the Dask scheduler at {lost} went away during the sweep ({done} of {len(table)} "
            "variants done; rerun with --resume to keep them)"
        )
    failed = [r for r in table if r["status"] != "done"]
    say(f"sweep: {len(table) - len(failed)} of {len(table)} variants done -> {out / 'sweep.csv'}", result=True)
    for r in failed:
        say(f"  {r['variant']}: {r['status']}")
    return 1 if failed else 0


def _render_on_dask(spec: SweepSpec, plans: list, rows: dict, log: _Log) -> str | None:
    """Render ``plans`` (name, overrides, folder, hash) as one Dask task each (`render_variant`
    with ``ship``), write each finished one into its folder here (`_commit_variant`) and its row
    into ``rows``. Returns the scheduler's address if it went away (the variants not finished
    are marked so), else None. The tasks left are cancelled on the way out, whatever the way."""
    from dask.distributed import as_completed

    from pmmw.distributed import cancel_quietly, dask_client, scheduler_lost
    from pmmw.trace.pool import default_workers

    with dask_client(spec.scheduler, spec.cluster, min(spec.workers or default_workers(), len(plans))) as client:
        # render_variant returns its errors; a lost worker's task is rescheduled (`distributed`)
        futures = {
            client.submit(
                render_variant, str(spec.scenario), ov, str(vd), 1, sh, True, key=f"pmmw-{name}-{sh}", pure=False
            ): (name, ov, vd, sh)
            for name, ov, vd, sh in plans
        }
        try:
            for fut in as_completed(list(futures)):
                name, overrides, vdir, shash = futures.pop(fut)
                try:
                    result = fut.result()
                except Exception as e:  # noqa: BLE001 - KilledWorker: the workers running it were lost too often
                    if scheduler_lost(client, e):
                        address = client.scheduler.address
                        for n, *_ in plans:
                            rows.setdefault(
                                n,
                                {
                                    "status": f"failed: not rendered: the Dask scheduler at {address} went away",
                                    "exr": "",
                                    "wall_s": 0.0,
                                },
                            )
                        return address
                    result = {"status": f"failed: {type(e).__name__}: {str(e)[:200]}", "exr": "", "wall_s": 0.0}
                fut.release()  # its files are no longer held on the cluster
                rows[name] = _commit_variant(vdir, result, shash, overrides)
                log.update(rows)
        finally:
            cancel_quietly(client, futures)
    return None


def _moved(data: bytes, rel: str, old: str, new: Path) -> bytes:
    """A report ``rel`` (JSON or Markdown) rendered in the folder ``old``, naming ``new`` instead."""
    text = data.decode("utf-8")
    if rel.endswith(".json"):
        return text.replace(json.dumps(old)[1:-1], json.dumps(str(new))[1:-1]).encode("utf-8")
    return text.replace(old, str(new)).encode("utf-8")


def _commit_variant(vdir: Path, result: dict, shash: str, overrides: list[str]) -> dict:
    """Write a variant that a Dask task rendered (`render_variant` with ``ship``) into ``vdir``:
    its files staged and moved into place together (`io.rundir.Staging`), reports last, the
    folder it was rendered in replaced by ``vdir`` in them, then ``variant.json``. Returns its
    table row: failed, with the reason, when the files cannot be written."""
    from pmmw.io.rundir import Staging, check_outputs

    files, where = result.pop("files", None), result.pop("rendered_in", "")
    if result["status"] != "done" or files is None:
        return result
    reports = [rel for rel in files if rel.endswith((".json", ".md"))]
    try:
        check_outputs(vdir, list(files), [], key="--out")
        with Staging(vdir) as staged:
            for rel, data in files.items():
                staged.path(rel).write_bytes(_moved(data, rel, where, vdir) if rel in reports and where else data)
            staged.commit([rel for rel in files if rel not in reports], last=reports)
        write_text_atomic(vdir / "variant.json", json.dumps({"hash": shash, "overrides": overrides}, indent=1))
    except UserError as e:  # an EnvironmentProblem too: the disk
        return {**result, "status": f"failed: {e}", "exr": ""}
    except OSError as e:
        return {**result, "status": f"failed: writing into {vdir}: {e}", "exr": ""}
    return {**result, "exr": str(vdir / result["exr"]) if result["exr"] else ""}


class _Log:
    """Progress of a sweep (`io.progress.StatusLine`): variants done/total, rays per second of the
    variants rendered, time left."""

    def __init__(self, total: int, quiet: bool) -> None:
        self.total = total
        self.line = None if quiet else StatusLine()
        self.t0 = time.perf_counter()
        self.skipped: int | None = None

    def update(self, rows: dict) -> None:
        if self.skipped is None:  # the first call: variants already done (--resume) or refused
            self.skipped = len(rows)
        if self.line is None:
            return
        done = len(rows)
        now = time.perf_counter() - self.t0
        rendered = done - self.skipped
        left = f"{now / rendered * (self.total - done):.0f} s" if rendered else "?"
        rays = sum(r.get("rays", 0) for r in rows.values())
        self.line.show(
            f"sweep: {done}/{self.total} variants, {rays / max(now, 1e-9) / 1e6:.3g} Mrays/s, {now:.0f} s, {left} left",
            now,
            done == self.total,
        )


def _row(spec: SweepSpec, out: Path, name: str, step: dict, result: dict) -> dict:
    """The table's row of variant ``name``: its values' labels (``step``: each key's position in
    its list, `variant_steps`), how it went, and its report's numbers."""
    row = {
        "variant": name,
        **{k: _label(spec, k, i) for k, i in step.items()},
        "status": result["status"],
        "exr": (str(Path(result["exr"]).relative_to(out)) if result.get("exr") else ""),
        "wall_s": result["wall_s"],
    }
    report = out / name / "report.json"
    if result["status"] == "done" and report.is_file():
        rep = json.loads(report.read_text())
        regions = rep.get("regions") or {}
        for region, chans in (regions.get("means") or {}).items():
            for c, v in chans.items():
                row[f"mean {region} {c} [K]"] = v
        band, f = rep.get("materials_band"), rep.get("frequency_hz")
        if band and "limited_by_hz" in band and f:
            outside = [m for m, spans in band["limited_by_hz"].items() if not _inside(f, spans)]
            row["inside stated ranges"] = not outside
            row["outside stated range"] = "; ".join(outside)
        lead = regions.get("channel", "Ey2")
        for pair, chans in (regions.get("contrasts") or {}).items():
            for c, v in chans.items():
                row[f"contrast {pair} {c} [K]"] = v["K"]
                row[f"contrast {pair} {c} [sigma]"] = v["sigma"]
            if lead in chans and "snr" in chans[lead]:  # the detection criterion in the report's channel
                row[f"snr {pair} {lead}"] = chans[lead]["snr"]
                row[f"detectable {pair} {lead}"] = chans[lead]["detectable"]
                row[f"snr_stderr {pair} {lead}"] = chans[lead].get("snr_stderr")
                row[f"pd {pair} {lead}"] = chans[lead].get("pd")
            judged = {c: v for c, v in chans.items() if isinstance(v.get("snr"), (int, float))}
            if judged:  # the variant's own verdict: the criterion in every channel (report.json's `verdicts`)
                best = max(judged, key=lambda c: judged[c]["snr"])
                row[f"detectable {pair} in any channel"] = any(bool(v.get("detectable")) for v in judged.values())
                row[f"best channel {pair}"] = f"{best} (SNR {judged[best]['snr']:.3g})"
    return row


def _inside(f: float, spans: list) -> bool:
    """Whether f [Hz] lies in one of the closed intervals ``spans`` ([[lo, hi], ...] [Hz], a
    report's `materials_band`), to the `FREQ_REL_TOL` that tells two frequencies apart."""
    return any(lo * (1 - FREQ_REL_TOL) <= f <= hi * (1 + FREQ_REL_TOL) for lo, hi in spans)


def write_table(path: Path, table: list[dict]) -> Path:
    cols = list(dict.fromkeys(k for row in table for k in row))
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=cols, lineterminator="\n")
    w.writeheader()
    for row in table:
        w.writerow({k: row.get(k, "") for k in cols})
    return write_text_atomic(path, buf.getvalue())
