"""The ``pmmw brdf`` job: options to a `Stack`, the method(s) run, the JSON summary
(`pmmw.reflectance` docstring, "Outputs"); the EXR maps and plots are `pmmw.reflectance.outputs`'.
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from pmmw.arrays import FloatArray
from pmmw.errors import UserError, UserErrors
from pmmw.physics import roughness as rough
from pmmw.reflectance.analytic_model import SHADOWING, analytic, analytic_totals
from pmmw.reflectance.grid import N_PHI, N_THETA, _cells, projected_solid_angle
from pmmw.reflectance.montecarlo import monte_carlo
from pmmw.reflectance.optics import flat_reflectance
from pmmw.reflectance.outputs import write_outputs
from pmmw.reflectance.stack import _C0, Stack, StackLayer, _frequency, _medium_eps, load_stack

__all__ = ["METHODS", "BrdfResult", "MethodResult", "roughness_spec_from_options", "run_brdf"]

METHODS = ("mc", "analytic", "both")


@dataclass
class MethodResult:
    """One method's maps and numbers.

    Attributes
    ----------
    mueller : ndarray, shape (91, 360, 4, 4), float64
        BRDF Mueller matrix [1/sr] per cell.
    stokes : ndarray, shape (4, 91, 360), float64
        ``mueller @ stokes_in / stokes_in[0]`` [1/sr]: I, Q, U, V.
    summary : dict
        JSON-ready numbers (see `run_brdf`).
    parts : dict
        Method-specific arrays: ``mc``: ``by_order`` (3, 91, 360, 4, 4) [1/sr] for orders 1, 2,
        >= 3; ``analytic``: ``single`` and ``double`` (91, 360, 4, 4) [1/sr].
    """

    mueller: np.ndarray
    stokes: np.ndarray
    summary: dict
    parts: dict = field(default_factory=dict)


@dataclass
class BrdfResult:
    """What `run_brdf` computed: per-method results and the JSON summary."""

    methods: dict
    summary: dict
    files: list


# The option each "command line" problem comes from: the substrate and roughness checks are
# shared with stack files and locate problems by key (`--n.n`, `roughness.ex`); a user who typed
# options is told the option alone.
_ROUGHNESS_OPTIONS = {
    "roughness.model": "--model",
    "roughness.ex": "--ex",
    "roughness.ey": "--ey",
    "roughness.m": "--m",
    "roughness.alpha": "--alpha",
    "roughness.alpha_x": "--alpha",
    "roughness.alpha_y": "--alpha-y",
    "roughness.gloss": "--gloss",
    "roughness.orientation_deg": "--orientation",
}


def _option_error(err: UserError) -> UserError:
    if isinstance(err, UserErrors):
        return UserErrors([_option_error(e) for e in err.errors])
    if err.file != "command line" or not err.key:
        return err
    return UserError(err.message, _ROUGHNESS_OPTIONS.get(err.key, err.key.split(".")[0]))


def _stack_from_options(
    n: str | complex | None,
    eps: str | complex | None,
    material: str | None,
    roughness_spec: dict | None,
    frequency: str | float | None,
    wavelength: str | float | None,
) -> Stack:
    f = _frequency(frequency, wavelength, "command line", "--frequency", "--wavelength")
    given = [k for k, v in (("--n", n), ("--eps", eps), ("--material", material)) if v is not None]
    if len(given) != 1:
        raise UserError(
            "give exactly one of --n, --eps, --material (or --stack FILE)",
            "command line",
            given[1] if len(given) > 1 else "--n",
        )
    entry = {"n": n} if n is not None else {"eps": eps} if eps is not None else {"material": material}
    eps_val, metal = _medium_eps(entry, frequency=f, file="command line", key=given[0])
    model = rough.make_model(roughness_spec, file="command line", key="roughness") if roughness_spec else None
    if material is not None:
        assert f is not None  # `_medium_eps` refused a material without a frequency
        return _material_stack(material, eps_val, metal, model, f)
    return Stack(
        layers=(StackLayer(eps=eps_val, roughness=model, metal=metal, name=given[0].lstrip("-")),), frequency=f
    )


def _material_stack(mid: str, eps_val: complex, metal: bool, model: rough.MicrofacetModel | None, f: float) -> Stack:
    """A database material as a stack: its ``roughness:`` (unless the options give one) and its
    coating, as the renderer sees it. Coating layers without roughness are coherent films on the
    interface below them; a layer with its own ``roughness:`` is a rough layer of its own."""
    from pmmw.scene.materials import MaterialDB
    from pmmw.surface.media import split_coating

    db = MaterialDB.load()
    mat = db.get(mid, file="command line", key="--material")
    rough_layers, films = split_coating(  # the renderer's grouping (temperatures do not matter here)
        [(db.get(x.material).eps_at(f), x.thickness, 0.0, x.roughness) for x in mat.coating], 2.0 * math.pi * f / _C0
    )

    def pairs(coat: Any) -> tuple:
        return () if coat is None else tuple(zip(coat.eps.tolist(), coat.thickness.tolist()))

    names = [x.material for x in mat.coating if x.roughness is not None]
    layers = [
        StackLayer(eps=x.eps, roughness=x.roughness, thickness=x.thickness, coating=pairs(x.films), name=name)
        for x, name in zip(rough_layers, names)
    ]
    layers.append(
        StackLayer(
            eps=eps_val,
            roughness=model if model is not None else mat.roughness,
            metal=metal,
            coating=pairs(films),
            name=mid,
        )
    )
    return Stack(layers=tuple(layers), frequency=f)


def roughness_spec_from_options(
    model: str | None = None,
    ex: float | None = None,
    ey: float | None = None,
    m: float | None = None,
    alpha: float | None = None,
    alpha_y: float | None = None,
    gloss: float | None = None,
    orientation: float | None = None,
) -> dict[str, object] | None:
    """The ``roughness:`` record implied by the command-line options (None: smooth)."""
    opts = {"ex": ex, "ey": ey, "m": m, "alpha": alpha, "alpha_y": alpha_y, "gloss": gloss}
    given = {k: v for k, v in opts.items() if v is not None}
    if model is None:
        if not given:
            return None
        if "ex" in given or "ey" in given:
            model = "ashikhmin_shirley"
        elif "m" in given:
            model = "blinn_phong"
        elif "gloss" in given:
            model = "blender_gloss"
        else:
            model = "ggx"
    spec: dict[str, object] = {"model": model}
    if model == "ashikhmin_shirley":
        if "ex" in given and "ey" not in given:
            given["ey"] = given["ex"]
        if "ey" in given and "ex" not in given:
            given["ex"] = given["ey"]
    if model in ("ggx", "beckmann") and "alpha_y" in given and "alpha" in given:
        given["alpha_x"] = given.pop("alpha")
    spec.update(given)
    if orientation is not None:
        spec["orientation_deg"] = orientation
    return spec


def _direction(theta_deg: float, phi_deg: float) -> FloatArray:
    th, ph = math.radians(theta_deg), math.radians(phi_deg)
    return np.array([math.sin(th) * math.cos(ph), math.sin(th) * math.sin(ph), math.cos(th)])


def _stokes_maps(mueller: FloatArray, stokes_in: FloatArray) -> FloatArray:
    s = np.einsum("...ij,j->...i", mueller, stokes_in / stokes_in[0])
    return np.moveaxis(s, -1, 0)


def _totals(mueller: FloatArray, stokes_in: FloatArray) -> tuple[FloatArray, FloatArray]:
    proj = projected_solid_angle()
    tot = np.einsum("ij,ijab->ab", proj, mueller)  # hemispherical Mueller matrix [-]
    s = tot @ (stokes_in / stokes_in[0])
    return tot, s


def _specular(mueller: FloatArray, wi: FloatArray) -> dict:
    ws = np.array([-wi[0], -wi[1], wi[2]])
    row, col = _cells(ws[None, :])
    m = mueller[row[0], col[0]]
    norm = m[0, 0] if m[0, 0] != 0 else 1.0
    return {
        "cell": [int(row[0]), int(col[0])],
        "M00": float(m[0, 0]),
        "m12": float(m[0, 1] / norm),
        "m33": float(m[2, 2] / norm),
        "m34": float(m[2, 3] / norm),
    }


def run_brdf(
    *,
    n: str | complex | None = None,
    eps: str | complex | None = None,
    material: str | None = None,
    stack: Stack | str | Path | None = None,
    frequency: str | float | None = None,
    wavelength: str | float | None = None,
    incidence: float = 0.0,
    azimuth: float = 0.0,
    stokes: Sequence[float] = (1.0, 0.0, 0.0, 0.0),
    model: str | None = None,
    ex: float | None = None,
    ey: float | None = None,
    m: float | None = None,
    alpha: float | None = None,
    alpha_y: float | None = None,
    gloss: float | None = None,
    orientation: float | None = None,
    method: str = "mc",
    samples: int = 1_000_000,
    seed: int = 0,
    shadowing: str = "smith",
    double: bool = True,
    double_samples: int = 256,
    mueller: bool = False,
    threshold: float = 1e-3,
    out: str | Path | None = None,
    plots: bool = True,
) -> BrdfResult:
    """The ``pmmw brdf`` job: build the surface, run the method(s), write the files.

    Parameters mirror the command-line options (docs/brdf.md). ``stack`` is a Stack or a path
    to a stack YAML file (then ``n``, ``eps``, ``material`` and the roughness options must be
    None). Angles in degrees. ``out`` None writes nothing.

    Returns
    -------
    BrdfResult
        ``summary`` holds, per method, ``total_reflectance`` (hemispherical integral of I over
        the incident I), the hemispherical Stokes vector and Mueller matrix, the specular cell's
        normalized Mueller elements, timings, and for ``mc`` the standard error,
        ``total_transmittance``, ``absorptance`` and ``lost``; plus ``flat_reflectance`` (the
        same stack with smooth interfaces).

    Raises
    ------
    UserError
        Bad options or stack file (with the option name or the file and key path).
    """
    t_start = time.perf_counter()
    if method not in METHODS:
        raise UserError(f"unknown method {method!r}; known: {', '.join(METHODS)}", "--method")
    if shadowing not in SHADOWING:
        raise UserError(f"unknown shadowing {shadowing!r}; known: {', '.join(SHADOWING)}", "--shadowing")
    try:
        stokes_in = np.array([float(v) for v in stokes], dtype=np.float64)
    except (TypeError, ValueError):
        raise UserError(f"expected four numbers I,Q,U,V, got {stokes!r}", "--stokes") from None
    if (
        stokes_in.shape != (4,)
        or not np.all(np.isfinite(stokes_in))
        or not stokes_in[0] > 0.0
        or np.sqrt(np.sum(stokes_in[1:] ** 2)) > stokes_in[0] * (1.0 + 1e-9)
    ):
        raise UserError(f"a Stokes vector needs I > 0 and Q^2 + U^2 + V^2 <= I^2, got {stokes!r}", "--stokes")
    if not (0.0 <= float(incidence) < 90.0):
        raise UserError(f"incidence must lie in [0, 90) degrees, got {incidence!r}", "--incidence")
    if not math.isfinite(float(azimuth)):
        raise UserError(f"azimuth must be finite, got {azimuth!r}", "--azimuth")
    if int(samples) < 1:
        raise UserError(f"samples must be >= 1, got {samples!r}", "--samples")
    if not (0.0 <= float(threshold) < 1.0):
        raise UserError(f"threshold must lie in [0, 1), got {threshold!r}", "--threshold")
    if int(double_samples) < 1:
        raise UserError(f"double-samples must be >= 1, got {double_samples!r}", "--double-samples")
    spec = roughness_spec_from_options(model, ex, ey, m, alpha, alpha_y, gloss, orientation)
    if stack is not None and (any(v is not None for v in (n, eps, material)) or spec is not None):
        raise UserError(
            "--stack describes the layers and their roughness: drop --n/--eps/--material and the roughness options",
            "--stack",
        )
    try:
        if stack is not None:
            st = stack if isinstance(stack, Stack) else load_stack(stack, frequency=frequency, wavelength=wavelength)
        else:
            st = _stack_from_options(n, eps, material, spec, frequency, wavelength)
    except UserError as err:
        raise _option_error(err) from None
    wi = _direction(float(incidence), float(azimuth))
    methods = ("mc", "analytic") if method == "both" else (method,)
    results: dict[str, MethodResult] = {}
    proj = projected_solid_angle()
    flat_r = flat_reflectance(st, math.radians(float(incidence)))
    for meth in methods:
        t0 = time.perf_counter()
        if meth == "mc":
            tally = monte_carlo(st, wi, stokes_in, samples=int(samples), seed=int(seed), threshold=float(threshold))
            by_order = tally.by_order / (int(samples) * proj[None, :, :, None, None])
            mm = by_order.sum(axis=0)
            mean_i = tally.i_sum / int(samples) / stokes_in[0]
            var_i = max(tally.i_sq / int(samples) / stokes_in[0] ** 2 - mean_i**2, 0.0)
            extra = {
                "total_reflectance_stderr": math.sqrt(var_i / int(samples)),
                "total_transmittance": tally.transmitted / int(samples),
                "absorptance": tally.absorbed / int(samples),
                "lost": tally.lost / int(samples),
                "samples": int(samples),
                "facet_interactions_per_ray": tally.events / int(samples),
                "rejection_fallbacks": tally.fallback_weights,
                "reflectance_by_order": [
                    float(np.einsum("ij,ij->", proj, by_order[o, :, :, 0, :] @ (stokes_in / stokes_in[0])))
                    for o in range(3)
                ],
            }
            parts = {"by_order": by_order}
        else:
            single, dbl = analytic(
                st, wi, shadowing=shadowing, double=bool(double), double_samples=int(double_samples), seed=int(seed)
            )
            mm = single + dbl
            sn = stokes_in / stokes_in[0]
            if st.layers[0].roughness is None:
                t1, t2 = _totals(single, stokes_in)[0], np.zeros((4, 4))
            else:
                t1, t2 = analytic_totals(st, wi, shadowing=shadowing, double=bool(double), seed=int(seed))
            extra = {
                "shadowing": shadowing,
                "double": bool(double),
                "single_reflectance": float((t1 @ sn)[0]),
                "double_reflectance": float((t2 @ sn)[0]),
                "grid_total_reflectance": float(_totals(mm, stokes_in)[1][0]),
            }
            exact_tot = t1 + t2
            parts = {"single": single, "double": dbl}
        stk = _stokes_maps(mm, stokes_in)
        tot, s_tot = _totals(mm, stokes_in)
        if meth == "analytic":
            # facet-space quadrature: accurate also for lobes narrower than a grid cell
            tot = exact_tot
            s_tot = tot @ (stokes_in / stokes_in[0])
        summary = {
            "total_reflectance": float(s_tot[0]),
            "hemispherical_stokes": [float(v) for v in s_tot],
            "hemispherical_mueller": tot.tolist(),
            "specular": _specular(mm, wi),
            "seconds": time.perf_counter() - t0,
        }
        summary.update(extra)
        results[meth] = MethodResult(mueller=mm, stokes=stk, summary=summary, parts=parts)
    summary = {
        "incidence_deg": float(incidence),
        "azimuth_deg": float(azimuth),
        "stokes_in": [float(v) for v in stokes_in],
        "stack": _describe(st),
        "grid": {
            "rows": "zenith 0..90 deg (1 deg cells)",
            "columns": "azimuth 0..359 deg (1 deg cells)",
            "shape": [N_THETA, N_PHI],
        },
        "flat_reflectance": flat_r,
        "methods": {k: v.summary for k, v in results.items()},
        "total_reflectance": results[methods[0]].summary["total_reflectance"],
    }
    files = []
    if out is not None:
        files = write_outputs(Path(out), results, summary, wi, bool(mueller), bool(plots))
    summary["seconds"] = time.perf_counter() - t_start
    if out is not None:
        from pmmw.io.atomic import write_text_atomic

        write_text_atomic(Path(out) / "brdf.json", json.dumps(summary, indent=2) + "\n")
    return BrdfResult(methods=results, summary=summary, files=files)


def _describe(st: Stack) -> dict:
    layers = []
    for layer in st.layers:
        d = {"name": layer.name, "eps": [layer.eps.real, layer.eps.imag], "metal": layer.metal}
        if layer.roughness is not None:
            d["roughness"] = {"model": layer.roughness.name, **layer.roughness.params()}
        if layer.thickness is not None:
            d["thickness_m"] = layer.thickness
        if layer.coating:
            d["coating"] = [{"eps": [e.real, e.imag], "thickness_m": t} for e, t in layer.coating]
        layers.append(d)
    return {"ambient_eps": [st.ambient_eps.real, st.ambient_eps.imag], "frequency_hz": st.frequency, "layers": layers}
