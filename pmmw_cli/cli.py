"""The ``pmmw`` command line (typer): parse arguments, call the pipeline; no physics here.

User errors (`pmmw.errors.UserError`) print one paragraph naming the file and key path and
exit with status 2, never with a traceback.
"""

from __future__ import annotations

import contextlib
import functools
import json
import math
import signal
import sys
from pathlib import Path
from typing import List, Optional

import typer
import yaml

from pmmw import __version__, interrupt
from pmmw.errors import UserError
from pmmw.io.inputs import check_input_path, format_suffix, name_too_long

app = typer.Typer(
    add_completion=False,
    no_args_is_help=True,
    help="pmmw: passive millimetre-wave imaging simulator (polarized geometrical optics).",
)
materials_app = typer.Typer(no_args_is_help=True, help="The material database: permittivity, temperature, source.")
app.add_typer(materials_app, name="materials")

EXIT_USER_ERROR = 2


def _print_version(value: bool):
    if value:
        typer.echo(f"pmmw {__version__}")
        raise typer.Exit()


@app.callback()
def _main(
    version: bool = typer.Option(
        False,
        "--version",
        "-V",
        callback=_print_version,
        is_eager=True,
        metavar="",
        help="Print the pmmw version and exit.",
    ),
):
    """pmmw: passive millimetre-wave imaging simulator (polarized geometrical optics)."""
    from pmmw_cli import progress

    progress.install()  # the library's progress and notes (`pmmw.io.progress`) on standard error


def _user_errors(fn):
    """One line and an exit status instead of a traceback: `UserError` 2, `EnvironmentProblem` 1,
    a signal 128 + N (`pmmw.interrupt`; a KeyboardInterrupt counts as SIGINT)."""

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        try:
            return fn(*args, **kwargs)
        except UserError as e:  # an EnvironmentProblem too, with its own status
            typer.echo(f"error: {e}", err=True)
            raise typer.Exit(getattr(e, "exit_status", EXIT_USER_ERROR)) from None
        except OSError as e:  # a path too long to look up, wherever it was given: the user's to shorten
            problem = name_too_long(e)
            if problem is None:
                raise
            typer.echo(f"error: {problem}", err=True)
            raise typer.Exit(EXIT_USER_ERROR) from None
        except (KeyboardInterrupt, interrupt.Interrupted) as e:
            stop = e if isinstance(e, interrupt.Interrupted) else interrupt.Interrupted(signal.SIGINT)
            interrupt.report(stop)
            raise typer.Exit(stop.status) from None

    return wrapper


SetOpt = typer.Option(None, "--set", metavar="KEY.PATH=VALUE", help="Override a scenario key (repeatable).")


@app.command()
@_user_errors
def render(
    scenario: Path = typer.Argument(..., help="Scenario YAML file."),
    out: Optional[Path] = typer.Option(None, "--out", help="Output folder (default: output.dir or ./out/<name>)."),
    set_: Optional[List[str]] = SetOpt,
    spp: Optional[int] = typer.Option(None, "--spp", min=1, help="Samples per pixel (render.spp)."),
    workers: Optional[int] = typer.Option(None, "--workers", min=1, help="Worker processes (default: all cores)."),
    seed: Optional[int] = typer.Option(None, "--seed", help="Random seed (render.seed)."),
    resume: bool = typer.Option(False, "--resume", metavar="", help="Reuse tiles finished by an interrupted run."),
    keep_tiles: bool = typer.Option(
        False, "--keep-tiles", metavar="", help="Keep per-tile files after the image is written."
    ),
    quiet: bool = typer.Option(False, "--quiet", "-q", metavar="", help="No progress bar; one summary line per image."),
    shard: Optional[str] = typer.Option(
        None, "--shard", metavar="I/N", help="Render only tiles I mod N (cluster jobs); assemble later with --resume."
    ),
    force: bool = typer.Option(
        False, "--force", metavar="", help="Render even when memory or disk look too small for it."
    ),
    executor: str = typer.Option(
        "local", "--executor", help="local (worker processes here) or dask (the tiles as tasks on a Dask cluster)."
    ),
    scheduler: Optional[str] = typer.Option(
        None,
        "--scheduler",
        metavar="ADDRESS",
        help="With dask: a running scheduler, e.g. tcp://host:8786 (default: a local cluster of --workers processes).",
    ),
    cluster: Optional[Path] = typer.Option(
        None, "--cluster", metavar="FILE.yaml", help="With dask: a dask-jobqueue cluster file (as for pmmw sweep)."
    ),
    figures: bool = typer.Option(
        False,
        "--figures",
        metavar="",
        help="Also draw the annotated figures (colour bars, the ideal image beside the sensor's, the "
        "regions named, depth, material): output.previews=figures.",
    ),
    show_timings: bool = typer.Option(
        False,
        "--timings",
        metavar="",
        help="Print where the time went at the end: when the command started, the "
        "pipeline was imported, the outputs checked, the kernels loaded, the "
        "first tile sent and its first ray traced (seconds after the process started), then each phase "
        "(scenario, materials, meshes, atmosphere, kernels, the worker's Embree scene, "
        "trace (of which the tiles traced), then each step after it: imager model, region statistics, EXR, previews, "
        "channel statistics, report, outputs flushed to disk, outputs moved into place, tiles removed, "
        "and their sum).",
    ),
):
    """Render a scenario to an EXR polarization stack and a report."""
    from pmmw import memory, timings

    timings.clear()
    timings.mark("command started")  # Python's start and the imports before this line
    from pmmw.pipeline import parse_shard
    from pmmw.pipeline import render as run

    timings.mark("pipeline imported")
    with memory.overridable("--force", force):  # --force also reads a mesh or sky texture past the memory check
        run(
            scenario,
            [*(set_ or []), *(["output.previews=figures"] if figures else [])],
            out=out,
            spp=spp,
            workers=workers,
            seed=seed,
            resume=resume,
            quiet=quiet,
            keep_tiles=keep_tiles,
            shard=parse_shard(shard),
            force=force,
            executor=executor,
            scheduler=scheduler,
            cluster=cluster,
        )
    timings.mark("done")
    if show_timings:
        typer.echo("\n".join(["timings:", *(f"  {line}" for line in timings.lines())]), err=True)


@app.command()
@_user_errors
def validate(
    scenario: Path = typer.Argument(
        ...,
        metavar="FILE",
        help="A scenario, sweep file, physical-optics job, brdf stack file or Dask cluster file (YAML).",
    ),
    set_: Optional[List[str]] = SetOpt,
    preview: Optional[Path] = typer.Option(
        None,
        "--preview",
        metavar="FILE.png",
        help="Also draw the view (distance to the first surface) with the regions outlined and named.",
    ),
):
    """Check any pmmw file as its kind (printed first) and every asset it names. Renders nothing."""
    from pmmw.filekinds import validate_file as run

    resolved = run(scenario, set_ or [], preview=preview)
    typer.echo(yaml.safe_dump(resolved, sort_keys=False, default_flow_style=None, width=100).rstrip())


@materials_app.command("list")
@_user_errors
def materials_list(
    frequency: Optional[str] = typer.Option(None, "--frequency", "-f", help="e.g. '95 GHz': show eps there."),
):
    """List every material id with its kind, permittivity, temperature and source."""
    from pmmw.scene.materials import MaterialDB, format_material_table

    f = _frequency(frequency) if frequency else None
    typer.echo(format_material_table(MaterialDB.load(), f))


@materials_app.command("show")
@_user_errors
def materials_show(
    material_id: str = typer.Argument(..., metavar="ID"),
    frequency: Optional[str] = typer.Option(None, "--frequency", "-f", help="e.g. '95 GHz'."),
    plot: Optional[Path] = typer.Option(
        None, "--plot", metavar="FILE.png", help="Draw eps' and eps'' against frequency, 10-1000 GHz."
    ),
    compare: Optional[List[str]] = typer.Option(
        None, "--compare", metavar="ID", help="With --plot: also mark this material's values (repeatable)."
    ),
    temperature: Optional[str] = typer.Option(
        None, "--temperature", help="With --plot: evaluate a model at this temperature, e.g. '280 K'."
    ),
):
    """Show one material: its permittivity table (or value at a frequency), coating, source."""
    from pmmw.scene.materials import MaterialDB, format_material, plot_materials
    from pmmw.units import parse_quantity

    db = MaterialDB.load()
    f = _frequency(frequency) if frequency else None
    typer.echo(format_material(db, material_id, f))
    if plot is not None:
        t = parse_quantity(temperature, "temperature", file="--temperature") if temperature else None
        if t is not None and not t > 0.0:  # the bound of every temperature key (config.schema)
            raise UserError(f"temperature must be > 0 K, got {temperature!r}", "--temperature")
        typer.echo(f"wrote {plot_materials(db, [material_id, *(compare or [])], plot, temperature=t)}")


@app.command()
@_user_errors
def sky(
    frequency: str = typer.Option(..., "--frequency", "-f", help="e.g. '95 GHz'."),
    atmosphere: Optional[Path] = typer.Option(None, "--atmosphere", help="YAML: an atmosphere mapping or a scenario."),
    profile: Optional[str] = typer.Option(
        None, "--profile", help="ITU-R P.835 profile, e.g. standard, mid_latitude_winter."
    ),
    layer: Optional[List[str]] = typer.Option(
        None,
        "--layer",
        metavar="KIND,BASE,TOP,AMOUNT",
        help="Weather slab, e.g. 'fog,0 m,600 m,0.3 g/m3' or 'rain,0,3 km,10 mm/h'.",
    ),
    ground_temperature: Optional[str] = typer.Option(None, "--ground-temperature"),
    humidity: Optional[str] = typer.Option(
        None, "--humidity", help="Water-vapour density at the ground, e.g. '7.5 g/m3'."
    ),
    elevations: str = typer.Option("5,10,15,20,30,45,60,90", "--elevations", help="Elevations in degrees."),
    fmt: str = typer.Option("table", "--format", help="table or csv."),
    exr: Optional[Path] = typer.Option(None, "--exr", help="Write an equirectangular Tv/Th map (a sky texture)."),
    plot: Optional[Path] = typer.Option(
        None, "--plot", help="Write a PNG of T against elevation for several weathers."
    ),
):
    """Sky brightness temperature against elevation and polarization, from the layered atmosphere."""
    from pmmw import sky_table as skycmd

    f = _frequency(frequency)
    if fmt not in ("table", "csv"):
        raise UserError(f"expected table or csv, got {fmt!r}", file="--format")
    els = skycmd.parse_elevations(elevations, "--elevations")
    atm = skycmd.load_atmosphere(atmosphere, profile, layer or [], ground_temperature, humidity)
    typer.echo(skycmd.format_table(skycmd.sky_table(atm, f, els), fmt))
    if exr is not None:
        skycmd.write_map(exr, atm, f)
    if plot is not None:
        skycmd.write_plot(plot, atm, f)


def _frequency(text: str, option: str = "--frequency") -> float:
    """A frequency option [Hz], within the range of pmmw's models."""
    from pmmw.config.schema import parse_frequency

    return parse_frequency(text, option)


def _count(text: str, option: str) -> int:
    """``1000000``, ``1e6`` or ``1_000_000`` -> int (a whole number; the range is checked later)."""
    try:
        value = float(text.replace("_", ""))
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value == int(value)):
        raise UserError(f"expected a whole number like 1000000 or 1e6, got {text!r}", option)
    return int(value)


def _numbers(text: str, option: str, count: int, example: str) -> tuple:
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        values = ()
    if len(values) != count:
        raise UserError(f"expected {count} comma-separated numbers like {example}, got {text!r}", option)
    return values


def _brdf_report(summary: dict, files: list) -> str:
    """The short human summary of `pmmw brdf` (the JSON has everything)."""
    stokes_in = ", ".join(f"{v:g}" for v in summary["stokes_in"])
    lines = [
        (
            f"incidence {summary['incidence_deg']:g} deg, azimuth {summary['azimuth_deg']:g} deg, "
            f"incident Stokes ({stokes_in})"
        )
    ]
    for meth, s in summary["methods"].items():
        if meth == "mc":
            orders = " / ".join(f"{v:.5f}" for v in s["reflectance_by_order"])
            lines.append(
                f"total reflectance, mc:       {s['total_reflectance']:.5f} +- "
                f"{s['total_reflectance_stderr']:.5f} (standard error; {s['samples']} rays, "
                f"{s['seconds']:.1f} s)"
            )
            lines.append(f"  by facet interactions 1 / 2 / >= 3: {orders}")
        else:
            lines.append(
                f"total reflectance, analytic: {s['total_reflectance']:.5f} = single "
                f"{s['single_reflectance']:.5f} + double {s['double_reflectance']:.5f} "
                f"(shadowing {s['shadowing']}, {s['seconds']:.1f} s)"
            )
    lines.append(f"flat reflectance:            {summary['flat_reflectance']:.5f} (the same stack, smooth)")
    if files:
        lines.append("wrote " + ", ".join(str(f) for f in files))
    return "\n".join(lines)


@app.command()
@_user_errors
def brdf(
    n: Optional[str] = typer.Option(None, "--n", metavar="N", help="Substrate complex index n + ik, e.g. 0.23+3.46j."),
    eps: Optional[str] = typer.Option(
        None, "--eps", metavar="EPS", help="Substrate permittivity eps' + i eps'', e.g. 5.5+0.5j (eps'' >= 0: lossy)."
    ),
    material: Optional[str] = typer.Option(
        None, "--material", metavar="ID", help="Substrate from the material database (needs --frequency)."
    ),
    stack: Optional[Path] = typer.Option(
        None,
        "--stack",
        metavar="FILE",
        help="Layered surface (YAML, docs/brdf.md) instead of --n/--eps/--material and the roughness options.",
    ),
    frequency: Optional[str] = typer.Option(None, "--frequency", "-f", help="e.g. '95 GHz' (or --wavelength)."),
    wavelength: Optional[str] = typer.Option(None, "--wavelength", help="e.g. '635 nm' (or --frequency)."),
    incidence: float = typer.Option(0.0, "--incidence", help="Zenith angle of the source in degrees, in [0, 90)."),
    azimuth: float = typer.Option(
        0.0, "--azimuth", help="Azimuth of the source in degrees; the specular direction is at azimuth + 180."
    ),
    stokes: str = typer.Option(
        "1,0,0,0",
        "--stokes",
        metavar="I,Q,U,V",
        help="Incident Stokes vector in the incident wave's (h, v) basis; 1,0,0,0 is unpolarized.",
    ),
    model: Optional[str] = typer.Option(
        None,
        "--model",
        help="Roughness model: ashikhmin_shirley, blinn_phong, ggx, beckmann, "
        "blender_gloss (default: implied by the parameters given).",
    ),
    ex: Optional[float] = typer.Option(None, "--ex", help="Ashikhmin-Shirley exponent along x (larger is smoother)."),
    ey: Optional[float] = typer.Option(None, "--ey", help="Ashikhmin-Shirley exponent along y (default --ex)."),
    m: Optional[float] = typer.Option(None, "--m", help="Blinn-Phong exponent (larger is smoother)."),
    alpha: Optional[float] = typer.Option(None, "--alpha", help="GGX / Beckmann roughness (alpha_x with --alpha-y)."),
    alpha_y: Optional[float] = typer.Option(None, "--alpha-y", help="GGX / Beckmann roughness along y (anisotropic)."),
    gloss: Optional[float] = typer.Option(None, "--gloss", help="Blender gloss in [0, 1] (1 = mirror)."),
    orientation: Optional[float] = typer.Option(
        None, "--orientation", help="Orientation of an anisotropic model's x axis in degrees."
    ),
    method: str = typer.Option(
        "mc", "--method", help="mc (Monte Carlo, Optics Express 2016), analytic (Stryjewski et al. 2009) or both."
    ),
    samples: str = typer.Option("1000000", "--samples", metavar="N", help="Monte Carlo rays, e.g. 1000000 or 1e6."),
    seed: int = typer.Option(0, "--seed", help="Random seed (same seed, same result)."),
    shadowing: str = typer.Option(
        "smith", "--shadowing", help="G of the analytic single term: smith, ashikhmin, torrance_sparrow, none."
    ),
    double: bool = typer.Option(True, "--double/--no-double", metavar="", help="Analytic double-reflection term."),
    double_samples: int = typer.Option(256, "--double-samples", help="Quadrature points of the analytic double term."),
    mueller: bool = typer.Option(
        False, "--mueller", metavar="", help="Also write the 16 Mueller elements M00..M33 to the EXR."
    ),
    threshold: float = typer.Option(
        1e-3, "--threshold", help="Russian roulette below this path power (unbiased), in [0, 1)."
    ),
    out: Path = typer.Option(Path("out/brdf"), "--out", help="Output folder: brdf_<method>.exr, PNGs, brdf.json."),
    plots: bool = typer.Option(
        True, "--plots/--no-plots", metavar="", help="Write the PNG maps and the in-plane plot."
    ),
    as_json: bool = typer.Option(
        False, "--json", metavar="", help="Print the JSON summary (brdf.json) instead of the text one."
    ),
):
    """Polarized BRDF of a rough (layered) surface on Optics Express 2016's 1-degree hemispherical grid."""
    from pmmw.reflectance import run_brdf

    res = run_brdf(
        n=n,
        eps=eps,
        material=material,
        stack=stack,
        frequency=frequency,
        wavelength=wavelength,
        incidence=incidence,
        azimuth=azimuth,
        stokes=_numbers(stokes, "--stokes", 4, "1,0,0,0"),
        model=model,
        ex=ex,
        ey=ey,
        m=m,
        alpha=alpha,
        alpha_y=alpha_y,
        gloss=gloss,
        orientation=orientation,
        method=method,
        samples=_count(samples, "--samples"),
        seed=seed,
        shadowing=shadowing,
        double=double,
        double_samples=double_samples,
        mueller=mueller,
        threshold=threshold,
        out=out,
        plots=plots,
    )
    if as_json:
        typer.echo(json.dumps(res.summary, indent=2))
    else:
        typer.echo(_brdf_report(res.summary, [*res.files, out / "brdf.json"]))


@app.command()
@_user_errors
def sweep(
    scenario: Path = typer.Argument(..., help="Scenario YAML, or a sweep file (scenario, grid, zip, executor, ...)."),
    grid: Optional[List[str]] = typer.Option(
        None,
        "--grid",
        metavar="KEY=LIST",
        help="A key and its values, e.g. 'frequency=[35 GHz, 95 GHz]' or "
        "'imager.noise=linspace(1 K, 4 K, 4)' (repeatable).",
    ),
    out: Optional[Path] = typer.Option(None, "--out", help="Sweep folder (default ./out/<scenario>_sweep)."),
    zip_: bool = typer.Option(
        False, "--zip", metavar="", help="The lists side by side (a flight path) instead of every combination."
    ),
    executor: Optional[str] = typer.Option(None, "--executor", help="local (default) or dask."),
    scheduler: Optional[str] = typer.Option(
        None, "--scheduler", metavar="ADDRESS", help="A running Dask scheduler, e.g. tcp://host:8786."
    ),
    cluster: Optional[Path] = typer.Option(
        None,
        "--cluster",
        metavar="FILE.yaml",
        help="A dask-jobqueue cluster (kind: slurm|pbs|sge|lsf, queue, cores, memory, walltime, jobs).",
    ),
    workers: Optional[int] = typer.Option(
        None, "--workers", min=1, help="Local: processes per render; dask LocalCluster: workers."
    ),
    resume: bool = typer.Option(
        False, "--resume", metavar="", help="Skip variants already rendered with the same inputs."
    ),
    dry_run: bool = typer.Option(
        False, "--dry-run", metavar="", help="Print the batch job script of --cluster and stop."
    ),
    quiet: bool = typer.Option(False, "--quiet", "-q", metavar="", help="No progress line."),
):
    """Render a grid of variants of a scenario; write sweep.csv and a trade-study report."""
    from pmmw.io.yamlio import read_yaml
    from pmmw.sweeps.run import SweepSpec, job_script, load_sweep_file, parse_grid_options, run_sweep

    raw = read_yaml(scenario, "scenario or sweep file") if scenario.is_file() else None
    if isinstance(raw, dict) and "grid" in raw:
        spec = load_sweep_file(scenario)
        if grid:
            spec.grid += parse_grid_options(grid)
    else:
        if not grid:
            raise UserError("give at least one --grid KEY=LIST (or a sweep file)", "--grid")
        spec = SweepSpec(scenario=scenario, grid=parse_grid_options(grid))
    spec.zip = True if zip_ else spec.zip
    spec.executor = executor or spec.executor
    spec.scheduler = scheduler or spec.scheduler
    spec.cluster = cluster or spec.cluster
    spec.out = out or spec.out
    spec.workers = workers or spec.workers
    if (spec.scheduler or spec.cluster) and spec.executor == "local":
        spec.executor = "dask"
    if dry_run:  # the script on standard output, to be redirected into a file
        typer.echo(job_script(spec))
        raise typer.Exit(0)
    raise typer.Exit(run_sweep(spec, resume=resume, quiet=quiet))


@app.command()
@_user_errors
def po(
    mesh: Path = typer.Argument(
        ..., help="Mesh file (glTF/GLB, OBJ, PLY, STL), in metres, or a job YAML (configs/po_*.yaml)."
    ),
    material: Optional[str] = typer.Option(None, "--material", metavar="ID", help="Material id from the database."),
    eps: Optional[str] = typer.Option(None, "--eps", metavar="EPS", help="Permittivity eps' + i eps'', e.g. 5.5+0.5j."),
    frequency: Optional[str] = typer.Option(None, "--frequency", "-f", help="e.g. '95 GHz' (a mesh needs it)."),
    incidence: str = typer.Option(
        "0,0",
        "--incidence",
        metavar="THETA,PHI",
        help="Direction the wave comes from, degrees (theta from +z, phi from +x).",
    ),
    polarization: str = typer.Option("theta", "--polarization", help="Incident E along theta-hat or phi-hat."),
    theta: Optional[str] = typer.Option(
        None, "--theta", metavar="START:STOP:STEP", help="Observation theta in degrees (default 0:180:1)."
    ),
    phi: Optional[str] = typer.Option(
        None, "--phi", metavar="P1,P2,...", help="Observation phi cuts in degrees (default: the incidence's phi)."
    ),
    monostatic: bool = typer.Option(
        False, "--monostatic", metavar="", help="Each observation direction is also the incidence."
    ),
    bounces: int = typer.Option(
        1,
        "--bounces",
        help="Reflections whose currents radiate (1: physical optics; "
        "2+: ray tubes add the reflected waves' currents).",
    ),
    tube: Optional[str] = typer.Option(
        None, "--tube", metavar="LENGTH", help="Ray-tube side for --bounces > 1 (default: a quarter wavelength)."
    ),
    method: str = typer.Option(
        "auto",
        "--method",
        help="Far-field sum: direct, octree (aggregated, 1e-3 of the "
        "peak) or auto (octree from 1e8 lit facets x directions).",
    ),
    fmt: str = typer.Option("table", "--format", help="csv, json or table (to standard output)."),
    out: Optional[Path] = typer.Option(
        None,
        "--out",
        help="Also write po.csv, po.json, po.png, report.md (and po.exr for a full-sphere grid) in this folder.",
    ),
    plot: Optional[Path] = typer.Option(None, "--plot", metavar="FILE.png", help="Write a plot of RCS against theta."),
    force: bool = typer.Option(
        False,
        "--force",
        metavar="",
        help="Solve even when the estimated memory (facets, "
        "directions, the octree's patterns at this "
        "frequency, ray tubes) exceeds what is available.",
    ),
):
    """Radar cross section of a mesh by physical optics (bistatic pattern or monostatic cuts)."""
    from pmmw.io.lock import output_lock

    check_input_path(mesh)
    if format_suffix(mesh) in (".yaml", ".yml"):
        from pmmw.physical_optics.job import run_job

        for path in run_job(mesh, out, force):
            typer.echo(f"wrote {path}")
        return
    if frequency is None:
        raise UserError("a mesh needs --frequency, e.g. '95 GHz'", "--frequency")
    if fmt not in ("csv", "json", "table"):
        raise UserError(f"expected csv, json or table, got {fmt!r}", "--format")
    with contextlib.ExitStack() as held:
        if out is not None:  # one writer per folder, from before the solve to the last file
            held.enter_context(output_lock(out))
        _po_run(
            mesh,
            material,
            eps,
            frequency,
            incidence,
            polarization,
            theta,
            phi,
            monostatic,
            bounces,
            tube,
            method,
            fmt,
            out,
            plot,
            force,
        )


#: `pmmw po`'s line after a signal once it writes (each file is written whole or not at all)
WRITING_OUTCOME = "files already written in {out} are complete, the others missing; run again to write them all"


def _po_run(
    mesh,
    material,
    eps,
    frequency,
    incidence,
    polarization,
    theta,
    phi,
    monostatic,
    bounces,
    tube,
    method,
    fmt,
    out,
    plot,
    force=False,
):
    """`po` on a mesh, its output folder (if any) locked."""
    from pmmw.physical_optics.command import format_rows, run_po, write_plot, write_report, write_run
    from pmmw.units import parse_quantity

    res = run_po(
        mesh,
        material=material,
        eps=eps,
        frequency=_frequency(frequency),
        incidence=incidence,
        polarization=polarization,
        theta=theta,
        phi=phi,
        monostatic=monostatic,
        bounces=bounces,
        method=method,
        tube=None if tube is None else parse_quantity(tube, "length", file="--tube"),
        force=force,
    )
    typer.echo(format_rows(res, fmt))
    if out is None and plot is None:
        return
    with interrupt.outcome(WRITING_OUTCOME.format(out=out if out is not None else plot.parent)):
        if out is not None:
            written = write_run(res, out, "po", Path(mesh).name, *res.axes)
            observation = f"theta `{theta or '0:180:1'}`, phi `{phi or 'the incidence phi'}` (degrees)"
            written.append(write_report(out, Path(mesh).name, str(mesh), [("po", res)], observation, True))
            for path in written:
                typer.echo(f"wrote {path}", err=True)
        if plot is not None:
            write_plot(res, plot, Path(mesh).name)


def check_bench_target(target: Path) -> None:
    """`pmmw bench` writes ``target`` (Markdown) and its ``.json`` beside it: neither may replace a
    file it did not write (a Markdown page of `pmmw bench`'s, and the JSON written with it)."""
    md, js = target, target.with_suffix(".json")

    def ours(p: Path) -> bool:
        try:
            return p.is_file() and not p.is_symlink() and b"pmmw bench" in p.read_bytes()[:2048]
        except OSError:
            return False

    for p in (md, js):
        if (p.exists() or p.is_symlink()) and not (ours(md) and (p == md or p.is_file())):
            raise UserError(
                f"{p} exists and is not a page pmmw bench wrote: pmmw does not replace it; give another --out", "--out"
            )


@app.command()
@_user_errors
def bench(
    scenarios: Optional[List[Path]] = typer.Argument(None, help="Scenario YAML files."),
    spp: str = typer.Option("1,2,4,8,16,32", "--spp", help="Comma-separated samples per pixel to try."),
    strategies: str = typer.Option("split,stochastic,hybrid", "--strategies", help="Sampling strategies to compare."),
    reference_spp: int = typer.Option(256, "--reference-spp", min=1, help="Samples of the cached reference render."),
    workers: Optional[int] = typer.Option(None, "--workers", min=1),
    set_: Optional[List[str]] = SetOpt,
    out: Optional[Path] = typer.Option(
        None,
        "--out",
        help="Markdown table, plots and JSON beside it (default out/bench/benchmarks.md, or benchmarks_po.md).",
    ),
    write_docs: bool = typer.Option(
        False,
        "--write-docs",
        metavar="",
        help="Write the committed docs/benchmarks.md (docs/benchmarks_po.md with --po) instead.",
    ),
    cache: Path = typer.Option(Path(".pmmw-cache"), "--cache", help="Where reference renders are cached."),
    with_scaling: bool = typer.Option(
        False, "--scaling", metavar="", help="Also measure cost against triangle count (1e3-1e6)."
    ),
    render_times: Optional[List[Path]] = typer.Option(
        None, "--render-times", help="Also time these configs as shipped (repeatable)."
    ),
    skip_configs: Optional[List[Path]] = typer.Option(
        None, "--skips", help="Also measure what each skip saves on these configs (repeatable)."
    ),
    po: bool = typer.Option(
        False, "--po", metavar="", help="Instead: physical optics, direct sum against octree (docs/benchmarks_po.md)."
    ),
    anchor: Optional[Path] = typer.Option(
        None,
        "--anchor",
        metavar="PYTHON",
        help="Also pmmw against Mitsuba 3 on the speed anchor, alternating: PYTHON of an environment "
        "with the bench extra (DRJIT_LIBLLVM_PATH: libLLVM, default Debian's libllvm19).",
    ),
    anchor_rounds: int = typer.Option(3, "--anchor-rounds", min=1, help="Alternating rounds of --anchor."),
):
    """Run time against error for each scenario and sampling strategy (into out/bench/)."""
    if out is not None and write_docs:
        raise UserError("give --out or --write-docs, not both", "--write-docs")
    name = "benchmarks_po.md" if po else "benchmarks.md"
    target = out or (Path("docs") / name if write_docs else Path("out") / "bench" / name)
    check_bench_target(target)
    if anchor is not None:  # checked before anything runs: a typo would otherwise cost every benchmark first
        if po:
            raise UserError("--po measures physical optics only: give --anchor without --po", file="--anchor")
        from pmmw_cli import bench_anchor

        bench_anchor.check(anchor)
    target.parent.mkdir(parents=True, exist_ok=True)
    if po:
        from pmmw_cli.bench_po import run as run_po_bench

        run_po_bench(target, command="pmmw bench " + " ".join(sys.argv[2:]))
        typer.echo(f"wrote {target}")
        return
    from pmmw_cli.bench import STRATEGIES
    from pmmw_cli.bench import bench as run

    try:
        spp_list = tuple(int(v) for v in spp.split(","))
    except ValueError:
        raise UserError(f"expected integers like 1,2,4, got {spp!r}", file="--spp") from None
    strats = tuple(v.strip() for v in strategies.split(","))
    bad = [v for v in strats if v not in STRATEGIES]
    if bad:
        raise UserError(f"unknown strategy {bad[0]!r}; known: {', '.join(STRATEGIES)}", file="--strategies")
    command = "pmmw bench " + " ".join(sys.argv[2:]) if len(sys.argv) > 2 else "pmmw bench"
    run(
        scenarios or [],
        spp_list=spp_list,
        strategies=strats,
        ref_spp=reference_spp,
        workers=workers,
        overrides=set_ or [],
        out_md=target,
        cache_dir=cache,
        command=command,
        with_scaling=with_scaling,
        render_times=tuple(render_times or ()),
        skip_configs=tuple(skip_configs or ()),
        anchor=anchor,
        anchor_rounds=anchor_rounds,
    )


#: [bytes] per pixel `view` takes beyond reading the channel: the figure's copies of the image
#: (float64, the display range's sort, matplotlib's drawing): 102 measured at 8 Mpx, and a
#: 20000 x 10000 image took 21.5 GB before its size was checked
VIEW_BYTES_PER_PIXEL = 128


@app.command()
@_user_errors
def view(
    exr: Path = typer.Argument(..., help="An EXR written by pmmw render (or any EXR of temperatures)."),
    channel: str = typer.Option("I", "--channel", "-c", help="Channel, e.g. Ey2, ideal.I, aux.depth."),
    out: Optional[Path] = typer.Option(
        None, "--out", help="PNG to write (default: beside the EXR, <name>_<channel>.png)."
    ),
):
    """Write any channel of an EXR as a preview with a colour bar and a title."""
    from pmmw.io.exr import image_size, read_exr
    from pmmw.io.preview import write_figure

    if not exr.is_file():
        raise UserError("file not found", exr)
    names = image_size(exr)[2]
    if channel not in names:
        raise UserError(f"no channel {channel!r}; the file has {', '.join(sorted(names))}", exr, "--channel")
    # the size checked from the header first, with what the figure takes per pixel
    chans, attrs = read_exr(exr, channels=[channel], bytes_per_pixel=VIEW_BYTES_PER_PIXEL)
    f = attrs.get("pmmw:frequency_hz")
    title = f"{exr.stem}: {channel}" + (f", {float(f) / 1e9:g} GHz" if f is not None else "")
    from pmmw.pipeline import channel_quantity

    units = channel_quantity(channel)
    path = out or exr.with_name(f"{exr.stem}_{channel.replace('.', '_')}.png")
    lo, hi = write_figure(path, [(None, chans[channel])], title=title, units=units[0], quantity=units[1])
    typer.echo(f"wrote {path} (black {lo:.4g}, white {hi:.4g} {units[0]})")


@app.command()
def version():
    """Print the pmmw version."""
    typer.echo(f"pmmw {__version__}")
