"""Scenario -> scene -> trace jobs -> process pool -> images -> imager model -> files.

Parse, then resolve, then build: the scenario is validated first (`pmmw.config`), every
material id and asset is resolved and checked (all user errors reported together), and only then
are meshes loaded, Embree scenes built and rays traced.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from types import SimpleNamespace
from typing import TYPE_CHECKING, Any

import numpy as np

from pmmw import __version__, timings
from pmmw.config import load_scenario
from pmmw.config.load import scenario_to_display
from pmmw.config.schema import FREQUENCY_RANGE
from pmmw.constants import C0
from pmmw.errors import UserError, UserErrors, clear_warnings, collected_warnings, warn
from pmmw.imaging import detection
from pmmw.imaging.antenna import (
    Aperture,
    FieldPSF,
    antenna_kernel,
    beam_report,
    gaussian_feed_spillover,
    pixel_field_angles,
)
from pmmw.imaging.imager import apply_imager, blur_adjoint, error_footprint, psf_kernel, self_adjoint
from pmmw.imaging.receiver import Receiver, dwell_time, noise_temperature
from pmmw.io.atomic import synced_together
from pmmw.io.exr import write_exr
from pmmw.io.lock import FolderLock
from pmmw.io.preview import (
    region_colour_names,
    write_depth_figure,
    write_figure,
    write_material_figure,
    write_preview,
    write_regions_figure,
    write_regions_png,
)
from pmmw.io.progress import StatusLine, say
from pmmw.io.report import write_report
from pmmw.io.rundir import Staging, check_outputs, made_by_pmmw, os_problem, remove_stale_staging
from pmmw.io.tilestore import (
    TILE_ROOT,
    claim,
    deletable,
    own_folders,
    remove_folder,
    remove_root_if_empty,
)
from pmmw.physics.jones import stokes_images
from pmmw.scene.camera import Camera
from pmmw.scene.geometry import asset_files, build_geometry, file_up_axis
from pmmw.scene.materials import MaterialDB, band_text, stated_band
from pmmw.scene.sky import make_sky
from pmmw.surface.media import BLACKBODY, KIND_CODES, METAL, build_media  # build_media: also pipeline's, as before
from pmmw.trace.job import RenderSettings, TraceJob
from pmmw.trace.pool import TILES, assemble, default_workers, render_tiles

if TYPE_CHECKING:
    from pmmw.atmosphere.model import AtmosphereModel
    from pmmw.config.schema import Region, ScenarioConfig
    from pmmw.scene.geometry import SceneGeometry
    from pmmw.trace.pool import Image

CHANNELS = ("I", "Q", "U", "V", "Ex2", "Ey2")


@dataclass
class Resolved:
    """A scenario with its materials and geometry resolved, ready to make trace jobs."""

    scenario: ScenarioConfig
    db: MaterialDB
    geometry: SceneGeometry
    # the imager's PSF kernels made so far, by what each depends on (`imager_kernel`): a render's
    # adaptive sampling and imager model share one, and a loaded scene's renders (`pmmw.load`) share
    # them across renders
    kernels: dict = field(default_factory=dict)


def resolve(
    path: str | Path,
    overrides: Sequence[str] = (),
    cli: dict | None = None,
    data: dict | None = None,
    values: dict | None = None,
) -> Resolved:
    """Load and check the scenario and every asset it names; raise `UserErrors` on problems.
    ``data``, ``values``: a scenario mapping and typed overrides (`config.load_scenario`)."""
    with timings.phase("scenario"):
        scn = load_scenario(path, list(overrides), cli=cli, data=data, values=values)
    with timings.phase("materials"):
        db = material_database(scn)
        check_material_ids(scn.scene, db, scn.source_file)
    with timings.phase("meshes"):
        geom = build_geometry(scn.scene, scenario_file=scn.source_file)
    refracting = {m for m in geom.material_ids if db.get(m).kind == "dielectric"}
    for obj, tight in zip(geom.objects, geom.object_watertight):
        mats = {
            geom.material_ids[i] for i in np.unique(geom.face_material[geom.face_object == geom.objects.index(obj)])
        }
        if not tight and mats & refracting:
            warn(
                f"{obj} is not watertight but refracts ({', '.join(sorted(mats & refracting))}): "
                "rays that enter it may not find the way out; close the mesh or use kind opaque/thin"
            )
    return Resolved(scn, db, geom)


def material_database(scn: ScenarioConfig) -> MaterialDB:
    """The database with the scenario's ``materials:`` overrides, checked."""
    db = MaterialDB.load().with_overrides(dict(scn.materials), file=scn.source_file)
    db.check()
    return db


def check_material_ids(entries: Sequence[Any], db: MaterialDB, file: str | Path | None) -> None:
    """Every material id the scene entries (``material`` or ``materials``) name exists in ``db``;
    all unknown ones are reported together, each by its key."""
    errors = []
    for entry in entries:
        pairs = (
            [(f"{entry.key}.material", entry.material)]
            if entry.material is not None
            else [(f"{entry.key}.materials.{name}", mid) for name, mid in entry.materials.items()]
        )
        for key, mid in pairs:
            try:
                db.get(mid, file=file, key=key)
            except UserError as e:
                errors.append(e)
    if errors:
        raise UserErrors(errors)


def variant_check() -> Callable[[Any], None]:
    """A check of one sweep variant's scenario for `sweeps.spec.check_variants`: its ``materials:``
    overrides and every material id its scene names (as `resolve` checks them, without reading a
    mesh). The database is built once per distinct ``materials:`` map, so a sweep over poses reads
    it once.

    Returns
    -------
    callable
        ``check(scenario)``, raising `UserError` or `UserErrors`.
    """
    dbs: dict[str, MaterialDB] = {}

    def check(scn: ScenarioConfig) -> None:
        k = json.dumps(scenario_to_display(scn).get("materials") or {}, sort_keys=True, default=str)
        if k not in dbs:
            dbs[k] = material_database(scn)
        check_material_ids(scn.scene, dbs[k], scn.source_file)

    return check


def aux_channels(img: Image, aux: Sequence[str]) -> dict[str, np.ndarray]:
    """The auxiliary EXR channels asked for in ``output.aux`` (stderr, depth, material, samples)
    of an assembled image, float32."""
    channels = {}
    if "stderr" in aux:
        err = stokes_images(img.stderr)
        channels["aux.stderr.I"] = np.sqrt(img.stderr[..., 0] ** 2 + img.stderr[..., 1] ** 2).astype(np.float32)
        channels["aux.stderr.Ex2"] = err["Ex2"].astype(np.float32)
        channels["aux.stderr.Ey2"] = err["Ey2"].astype(np.float32)
    if "depth" in aux:
        channels["aux.depth"] = img.depth.astype(np.float32)
    if "material" in aux:
        channels["aux.material"] = img.material.astype(np.float32)
    if "samples" in aux:
        channels["aux.samples"] = img.samples.astype(np.float32)
    if "truncated" in aux:
        channels["aux.truncated"] = img.truncated[..., 0].astype(np.float32)
        channels["aux.truncation_bound"] = img.truncated[..., 1].astype(np.float32)
    return channels


_AUX_QUANTITIES = {
    "aux.depth": ("m", "distance to the first hit"),
    "aux.material": ("-", "material index of the first hit"),
    "aux.samples": ("-", "samples per pixel"),
    "aux.truncated": ("-", "fraction of power ended by max_depth"),
    "aux.truncation_bound": ("K", "truncation bound"),
}


def channel_quantity(name: str) -> tuple[str, str]:
    """(units, quantity) of an EXR channel of pmmw's (`aux_channels` and the Stokes channels)."""
    if name.startswith("aux.stderr."):
        return "K", "Monte Carlo standard error"
    return _AUX_QUANTITIES.get(name, ("K", "brightness temperature"))


def traced_settings(scn: ScenarioConfig) -> dict:
    """The resolved scenario without what leaves the traced tiles unchanged (output settings,
    worker count): what `scenario_hash` hashes and a tile folder's manifest records."""
    d = scenario_to_display(scn)
    d.pop("output", None)
    d["render"].pop("workers", None)
    return d


def scenario_hash(scn: ScenarioConfig, db: MaterialDB | None = None, files: Sequence[Path] | None = None) -> str:
    """Hash of everything that changes the traced tiles (not workers, not output settings): the
    scenario, the pmmw version, every byte of every file the trace reads (`input_files`: meshes
    with their glTF buffers, OBJ material libraries and textures, the sky texture) and, given the
    resolved database, every material in it (an edited ``materials/*.yaml`` must not reuse old
    tiles either). ``files``: `input_files` when the caller has them already."""
    d = traced_settings(scn)
    h = hashlib.sha256((json.dumps(d, sort_keys=True, default=str) + __version__).encode())
    if db is not None:
        h.update("".join(repr(db.get(m)) for m in db.ids()).encode())
    for path in input_files(scn) if files is None else files:
        try:
            h.update(f"{path.stat().st_size}\0".encode())  # delimits one file's bytes from the next's
            with open(path, "rb") as f:
                for block in iter(lambda: f.read(1 << 20), b""):
                    h.update(block)
        except OSError as e:
            raise UserError(f"cannot read: {e.strerror or e}", file=path) from None
    return h.hexdigest()[:16]


def input_files(scn: ScenarioConfig) -> list[Path]:
    """Every file a render of ``scn`` reads besides the material database: the scenario, each
    mesh and the files it names (`asset_files`), the sky texture."""
    # a scenario given as a mapping (the Python API) has no file: its content is in the settings
    files = [Path(scn.source_file)] if Path(scn.source_file).is_file() else []
    for e in scn.scene:
        files += asset_files(e.mesh)
    if scn.sky.file:
        files.append(Path(scn.sky.file))
    return list(dict.fromkeys(Path(p).resolve() for p in files))


def parse_shard(text: str | None) -> tuple[int, int] | None:
    """``"I/N"`` -> (I, N) with 1 <= I <= N (as a job array numbers its tasks); None -> None."""
    if text is None:
        return None
    try:
        i, n = (int(v) for v in text.split("/"))
    except ValueError:
        raise UserError(f"expected I/N (e.g. 3/16), got {text!r}", file="--shard") from None
    if not (n >= 1 and 1 <= i <= n):
        raise UserError(f"shards count from 1: need 1 <= I <= N, got {text!r}", file="--shard")
    return i, n


def make_job(res: Resolved, f: float) -> TraceJob:
    scn, geom = res.scenario, res.geometry
    im = scn.imager
    cam = Camera.look_at(
        im.position,
        im.look_at,
        im.up,
        im.fov,
        im.resolution,
        aperture_radius=im.aperture_diameter / 2.0,
        focus_distance=im.focus_distance,
    )
    r = scn.render
    footprint = 1.0
    if r.target_error is not None and im.aperture_diameter > 0.0:
        # adaptive sampling to the error left after the imager's blur (Integrator.render_tile)
        kernel = imager_kernel(scn, cam.pixel_angle, 2.0 * np.pi * f / C0, res.kernels)
        assert kernel is not None  # an aperture has one
        footprint = error_footprint(kernel)
    settings = RenderSettings(
        spp=r.spp,
        max_depth=r.max_depth,
        threshold=r.threshold,
        seed=r.seed,
        termination=r.termination,
        strategy=r.strategy,
        split_depth=r.split_depth,
        target_error=r.target_error,
        min_spp=min(r.min_spp, r.spp),
        tile=r.tile,
        aux=tuple(scn.output.aux),
        error_footprint=footprint,
        atmosphere_tolerance=r.atmosphere_tolerance,
    )
    with timings.phase("atmosphere"):
        atm = atmosphere_model(scn, f)
        sky = make_sky(scn.sky, f, atmosphere_model=atm)
    with timings.phase("media"):
        media = build_media(res.db, geom.material_ids, f, scn.render.default_temperature, scn.atmosphere)
    return TraceJob(
        vertices=geom.vertices,
        faces=geom.faces,
        face_normals=geom.face_normals,
        face_medium=(geom.face_material + 1).astype(np.int32),
        media=media,
        camera=cam,
        sky=sky,
        frequency=f,
        settings=settings,
        atmosphere=atm,
    )


def atmosphere_summary(job: TraceJob) -> dict:
    """What the layered atmosphere does to this scene (Murakowski 2014 reports path losses so)."""
    atm, cam = job.atmosphere, job.camera
    assert atm is not None  # asked of a layered atmosphere only
    target = np.asarray(cam.position) + cam.k * _target_distance(job)
    dist = float(np.linalg.norm(target - cam.position))
    return {
        "specific_attenuation_at_ground_dB_per_km": round(float(atm.specific_attenuation_db_km(0.0)), 4),
        "zenith_opacity_Np": round(float(atm.zenith_opacity()), 5),
        "zenith_sky_K": round(float(atm.sky_temperature(np.pi / 2)), 3),
        "target_distance_m": round(dist, 2),
        "path_loss_imager_to_target_dB": round(float(atm.path_loss_db(cam.position[2], target[2], dist)), 4),
    }


def _target_distance(job: TraceJob) -> float:
    """Distance along the optical axis to the scene (first hit of the central ray), or 1 km. One
    ray: the NumPy intersector, so that this process builds no Embree scene and its next render's
    workers are forked (`trace.pool._context`)."""
    from pmmw.trace.intersect import make_intersector

    isect = make_intersector(job.vertices, job.faces, kind="numpy")
    t, _ = isect.intersect(job.camera.position[None, :], job.camera.k[None, :])
    return float(t[0]) if np.isfinite(t[0]) else 1000.0


def atmosphere_model(scn: ScenarioConfig, f: float) -> AtmosphereModel | None:
    """The layered atmosphere at frequency f [Hz], or None (vacuum / uniform ambient medium)."""
    a = scn.atmosphere
    if a is None or a.model != "layered":
        return None
    from pmmw.atmosphere.model import Atmosphere, AtmosphereModel

    # a rain power law's entry holds across the imager's band around its frequency (f may be a sub-band)
    layers = a.weather_at(f, half_band=scn.imager.bandwidth / 2.0, file=scn.source_file)
    try:
        atm = Atmosphere(
            profile=a.profile,
            ground_temperature=a.ground_temperature,
            humidity=a.humidity,
            layers=layers,
            ground_altitude=a.ground_altitude,
        )
    except ValueError as e:
        raise UserError(str(e), file=scn.source_file, key="atmosphere") from None
    # the scattering solution stands on the ground the sky model puts below the horizon
    ground = scn.sky.ground_temperature if scn.sky is not None and scn.sky.model == "atmosphere" else None
    return AtmosphereModel(atm, f, ground_temperature=ground)


class _Progress:
    """Progress of a render (`io.progress.StatusLine`): tiles done/total, rays per second, time left."""

    def __init__(self, label: str, quiet: bool) -> None:
        self.label = label
        self.line = None if quiet else StatusLine()

    def note(self, text: str) -> None:
        """One line of its own (the kernels being compiled), unless quiet."""
        if self.line is not None:
            self.line.say(f"{self.label}: {text}")

    def __call__(self, done: int, total: int, rays: float, elapsed: float, left: float | None = None) -> None:
        """Show ``done`` of ``total`` tiles, the rays per second over ``elapsed`` [s] and the
        seconds ``left`` the pool estimates (`trace.pool._Pace`; None: not known yet)."""
        if self.line is None:
            return
        rate = rays / elapsed if elapsed > 0 else 0.0
        when = "   ... s left" if left is None else f"{left:5.0f} s left"
        self.line.show(f"{self.label}: tiles {done}/{total}  {rate / 1e6:.2f} Mrays/s  {when}", elapsed, done == total)


def region_shapes(regions: Mapping[str, Region], cam: Camera) -> dict[str, tuple | None]:
    """The named regions (`output.regions`) in image coordinates [px] (x right, y down, pixel k
    spanning [k, k + 1)): ``("box", x0, y0, x1, y1)`` or ``("circle", u, v, radius)``, None for a
    centre behind the imager."""
    shapes: dict[str, tuple | None] = {}
    focal = cam.width / 2.0 / np.tan(cam.fov / 2.0)  # [px] the pinhole's focal length
    for name, r in regions.items():
        if r.box is not None:
            shapes[name] = ("box", *(float(x) for x in r.box))
            continue
        bounds = getattr(r, "bounds", None)
        if bounds is not None:  # the rectangle the world box's corners project into
            lo, hi = (np.asarray(c, float) for c in bounds)
            corners = np.array(
                [[(lo, hi)[i][0], (lo, hi)[j][1], (lo, hi)[k][2]] for i in (0, 1) for j in (0, 1) for k in (0, 1)]
            )
            u, v, depth = cam.image_coordinates(corners)
            shapes[name] = (
                (
                    "box",
                    float(np.floor(u.min())),
                    float(np.floor(v.min())),
                    float(np.ceil(u.max())),
                    float(np.ceil(v.max())),
                )
                if (depth > 0).all()
                else None
            )
            continue
        (u,), (v,), (depth,) = cam.image_coordinates(np.asarray(r.center, float)[None])
        if not depth > 0:  # in the imager's plane or behind it: not on the image
            shapes[name] = None
            continue
        unit = getattr(r, "radius_unit", "px")
        radius = {"px": r.radius, "m": focal * r.radius / depth, "rad": focal * np.tan(min(r.radius, 1.5))}[unit]
        shapes[name] = ("circle", float(u), float(v), float(radius))
    return shapes


def check_regions(scn: ScenarioConfig) -> dict:
    """``output.regions`` on the image, checked before rendering (`validate`): each region's
    pixel shape and pixel count. A region behind the imager or wholly outside the image is a
    `UserError` naming it; one partly outside is warned about.

    Returns
    -------
    dict
        name -> ``{"circle_px": [u, v, radius]}`` or ``{"box_px": [x0, y0, x1, y1]}``, with ``pixels``.
    """
    im = scn.imager
    cam = Camera.look_at(im.position, im.look_at, im.up, im.fov, im.resolution)
    masks = region_masks(scn.output.regions, cam)
    out, errors = {}, []
    for name, shape in region_shapes(scn.output.regions, cam).items():
        key = f"output.regions.{name}"
        if shape is None:
            errors.append(UserError("lies behind the imager", scn.source_file, key))
            continue
        n = int(masks[name].sum())
        out[name] = {f"{shape[0]}_px": [round(float(x), 2) for x in shape[1:]], "pixels": n}
        if n == 0:
            errors.append(
                UserError(
                    f"falls outside the {cam.width} x {cam.height} image (its {shape[0]} in pixels: "
                    f"{[round(float(x), 1) for x in shape[1:]]}); move it into view",
                    scn.source_file,
                    key,
                )
            )
        elif (
            shape[0] == "box"
            and (shape[1] < 0 or shape[2] < 0 or shape[3] > cam.width or shape[4] > cam.height)
            or shape[0] == "circle"
            and not (
                0 <= shape[1] - shape[3]
                and shape[1] + shape[3] <= cam.width
                and 0 <= shape[2] - shape[3]
                and shape[2] + shape[3] <= cam.height
            )
        ):
            warn(f"{key} lies partly outside the {cam.width} x {cam.height} image: only its {n} pixels inside count")
    if errors:
        raise UserErrors(errors) if len(errors) > 1 else errors[0]
    return out


def view_preview(scn: ScenarioConfig, geom: SceneGeometry, path: Path) -> Path:
    """What the imager sees, before any render: the first surface through each pixel centre,
    shaded by how squarely it faces the imager (|cos| of the angle between the ray and the face
    normal; the sky blank), with ``output.regions`` outlined and named
    (`io.preview.write_regions_figure`)."""
    from pmmw.trace.intersect import make_intersector

    im = scn.imager
    cam = Camera.look_at(im.position, im.look_at, im.up, im.fov, im.resolution)
    half = np.tan(cam.fov / 2.0)
    v, u = np.mgrid[0 : cam.height, 0 : cam.width] + 0.5
    # the pinhole direction through (u, v): the inverse of `Camera.image_coordinates`
    d = (
        cam.k
        + np.multiply.outer((2.0 * u / cam.width - 1.0) * half, cam.x)
        + np.multiply.outer((cam.height - 2.0 * v) / cam.width * half, cam.y)
    ).reshape(-1, 3)
    d /= np.linalg.norm(d, axis=1)[:, None]
    t, prim = make_intersector(geom.vertices, geom.faces).intersect(np.broadcast_to(cam.position, d.shape).copy(), d)
    tri = geom.vertices[geom.faces[np.maximum(prim, 0)]]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    facing = np.abs(np.sum(n * d, axis=1)) / np.maximum(np.linalg.norm(n, axis=1), 1e-300)
    shade = np.where(prim >= 0, facing, np.nan).reshape(cam.height, cam.width)
    shapes = region_shapes(scn.output.regions, cam) if scn.output.regions else {}
    if (path.exists() or path.is_symlink()) and not made_by_pmmw(path):  # a user's file is never replaced
        raise UserError("exists and is not a preview pmmw wrote: pmmw does not replace it; name another file", path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        write_regions_figure(
            path,
            shade,
            shapes,
            title=f"{scn.name}: the view and its regions",
            units="-",
            quantity="|cos| facing the imager",
        )
    except OSError as e:
        raise os_problem(e, path.parent, "write the preview") from None
    return path


def region_masks(regions: Mapping[str, Region], cam: Camera) -> dict[str, np.ndarray]:
    """Boolean (H, W) masks of the named regions (`output.regions`) on the image."""
    h, w = cam.height, cam.width
    yy, xx = np.ogrid[0:h, 0:w]  # (H, 1) and (1, W): each comparison broadcast to (H, W) once
    masks = {}
    for name, shape in region_shapes(regions, cam).items():
        if shape is None:
            masks[name] = np.zeros((h, w), bool)
        elif shape[0] == "box":
            x0, y0, x1, y1 = shape[1:]
            masks[name] = (xx >= x0) & (xx < x1) & (yy >= y0) & (yy < y1)
        else:
            u, v, radius = shape[1:]
            # a circle smaller than a pixel is the pixel holding its centre
            masks[name] = ((xx + 0.5 - u) ** 2 + (yy + 0.5 - v) ** 2 <= radius**2) | (
                (xx == np.floor(u)) & (yy == np.floor(v))
            )
    return masks


#: The channels of the region statistics: the two polarizations and their sum.
REGION_CHANNELS = ("Ex2", "Ey2", "I")


def report_channel(scn: ScenarioConfig) -> str:
    """The channel a render's report leads with (its verdicts, its regions preview): Ey2 when
    ``output.channels`` has it, else the first of them that the region statistics cover (Ex2,
    Ey2, I), else Ey2."""
    chans = getattr(scn.output, "channels", CHANNELS)  # a bare record (tests, validation) has all of them
    if "Ey2" in chans:
        return "Ey2"
    return next((c for c in chans if c in REGION_CHANNELS), "Ey2")


TRUNCATION_NOISE_FRACTION = 0.1  # region bias allowed from truncation, in noise sigmas
TRUNCATION_LIMIT_NO_NOISE = 0.5  # [K] the same without imager noise


def region_limit(noise: float) -> float:
    """Largest region bias or Monte Carlo error [K] worth no warning: a tenth of the noise
    sigma, or 0.5 K for a noiseless imager."""
    return TRUNCATION_NOISE_FRACTION * noise if noise > 0 else TRUNCATION_LIMIT_NO_NOISE


def region_stats(
    scn: ScenarioConfig,
    cam: Camera,
    sensor: Mapping[str, np.ndarray],
    img: Image | None = None,
    kernel: np.ndarray | Mapping[str, np.ndarray | None] | None = None,
    ideal: Mapping[str, np.ndarray] | None = None,
    noise_maps: Mapping[str, np.ndarray] | None = None,
) -> dict:
    """Per region: mean sensor temperature, its Monte Carlo standard error and truncation bound;
    per pair of regions: the contrast in K and noise sigmas, with the same two figures, and its
    detection by the one criterion (`imaging.detection`).

    Detection of a pair "a - b" (a the target, b the background) in channel c: ``snr`` =
    `detection.region_snr` of the contrast of the two regions' means in the ideal image
    (``ideal``, else `stokes_images` of ``img.mean``; before the PSF), over a's blurred footprint,
    in the channel's noise (`detection.channel_sigma`); ``snr_stderr`` its Monte Carlo standard
    error (that of the ideal contrast, weights mask / N, times footprint norm / noise);
    ``detectable`` ``snr >= 5``. All three None without imager noise (or without the ideal image).
    With a receiver the noise differs from pixel to pixel (``noise_maps``: channel -> (H, W) [K],
    from `imager_model`): the matched filter's noise is then `detection.effective_sigma` over the
    target's blurred footprint, and ``noise_K`` the mean of Ex2's and Ey2's per-pixel noise.
    ``verdicts`` gives each pair in words over its channels (`detection.contrast_verdict`),
    ``channel`` the one the report leads with (`report_channel`), ``criterion`` the criterion.

    A region's mean in the sensor image is a linear functional of the ideal image, with weights
    W = blur^T(mask / N) (`blur_adjoint`; W = mask / N without an aperture). Pixels' Monte Carlo
    errors are independent (each pixel has its own random rotations and each tile its own random
    stream), so the variance of the mean is sum W^2 var_k, and that of a contrast uses
    W_a - W_b. var_k is estimated from the pixel's two independent replicates (`pixel_samples`):
    d_k^2 / 4 with d_k their difference (`TileResult.replicate_diff`), unbiased and linear in the
    channels (d_I = d_Ex2 + d_Ey2), so it holds for the low-discrepancy sampling that the
    per-sample spread would overstate. Pixels with one sample have no second replicate: then the
    error is None. The truncation bound is sum |W| b with b the per-pixel bound of paths
    ended on a guessed temperature (`TileResult.truncated`), for Ex2 and Ey2 (twice it for I).
    """
    masks = region_masks(scn.output.regions, cam)

    def kernel_of(name: str) -> np.ndarray | None:
        # one PSF for the image, or each region's own (`region_kernels`: a field-dependent beam)
        return kernel.get(name) if isinstance(kernel, Mapping) else kernel

    chans = [c for c in REGION_CHANNELS if c in sensor]
    sigma = scn.imager.noise
    if noise_maps:
        sigma = float(np.mean([np.mean(noise_maps["Ex2"]), np.mean(noise_maps["Ey2"])]))
    if ideal is None and img is not None:
        ideal = stokes_images(img.mean)
    limit = region_limit(sigma)
    pfa = getattr(scn.output, "false_alarm", 1e-3)  # a bare record (tests, validation) has the default
    st = scn.render
    # each region's blurred footprint (`detection.footprint`), and its weights on the ideal image:
    # blur^T(mask / N), which is footprint / N where the blur is its own adjoint (`blur_adjoint`)
    footprints = {name: detection.footprint(m, kernel_of(name)) for name, m in masks.items() if m.any()}
    weights = {
        name: (
            (footprints[name] / m.sum() if self_adjoint(kern, m.shape) else blur_adjoint(m / m.sum(), kern))
            if (kern := kernel_of(name)) is not None
            else m / m.sum()
        )
        if m.any()
        else None
        for name, m in masks.items()
    }
    if img is not None:
        d = img.replicate_diff
        var_maps = {"Ex2": d[..., 0] ** 2 / 4.0, "Ey2": d[..., 1] ** 2 / 4.0, "I": (d[..., 0] + d[..., 1]) ** 2 / 4.0}
        two_everywhere = bool((img.samples >= 2).all())  # then no weight needs the check below
        frac_map, bound_map = (np.ascontiguousarray(img.truncated[..., i]) for i in (0, 1))  # summed often

    def mc_error(w, c, at=None):
        # at: w holds only the pixels at these (rows, columns), every other pixel's weight being 0
        if img is None or w is None:
            return None
        samples = img.samples if at is None else img.samples[at]
        if not two_everywhere and (samples[w != 0.0] < 2).any():
            return None
        var = var_maps[c] if at is None else var_maps[c][at]
        return float(np.sqrt(np.sum(w * w * var)))

    def bound(w):
        if img is None or w is None:
            return None, None
        aw = np.abs(w)
        return float(np.sum(aw * frac_map)), float(np.sum(aw * bound_map))

    ended = f"render.max_depth {st.max_depth}" + (
        " and render.threshold with termination: temperature" if st.termination == "temperature" else ""
    )
    means, pixels, errors, truncation = {}, {}, {}, {}
    for name, m in masks.items():
        pixels[name] = int(m.sum())
        means[name] = {c: (float(sensor[c][m].mean()) if m.any() else float("nan")) for c in chans}
        if not m.any():
            warn(f"output.regions.{name} falls outside the image")
            continue
        w = weights[name]
        errors[name] = {c: mc_error(w, c) for c in chans}
        frac, b = bound(w)
        if b is not None:
            truncation[name] = {"fraction": frac, "bound_K": b}
            if b > limit:
                warn(
                    f"output.regions.{name}: paths ended by {ended} carry {frac:.2%} of its power and can "
                    f"move its mean by up to {b:.3g} K, more than {limit:.3g} K "
                    f"({'a tenth of the noise sigma' if sigma > 0 else 'no imager noise'}): "
                    "raise render.max_depth"
                )
    names = list(masks)
    # detection: the ideal image's region means (weights mask / N, no blur) and the target's
    # blurred footprint (`detection.footprint_norm`)
    ideal_w = {name: (m / m.sum() if m.any() else None) for name, m in masks.items()}
    norms = {name: detection.norm_of(fp) for name, fp in footprints.items()}
    contrasts, verdicts = {}, {}
    unsettled = []  # (pair, channel, standard error [K]) of contrasts whose seeds would differ by more than `limit`
    for i, a in enumerate(names):
        for b_name in names[i + 1 :]:
            wa, wb = weights[a], weights[b_name]
            dw = None if wa is None or wb is None else wa - wb
            dw_ideal = at = None
            if dw is not None:  # the ideal contrast's weights, on the two regions' pixels alone
                at = np.nonzero(masks[a] | masks[b_name])
                ia, ib = ideal_w[a], ideal_w[b_name]
                assert ia is not None and ib is not None  # both regions have pixels, as their weights say
                dw_ideal = ia[at] - ib[at]
            _, tb = bound(dw)
            pair = {}
            for c in chans:
                k = means[a][c] - means[b_name][c]
                scale = (
                    detection.effective_sigma(masks[a], kernel_of(a), noise_maps[c])
                    if noise_maps
                    else detection.channel_sigma(sigma, c)
                )  # I carries sqrt(2) sigma
                err = mc_error(dw, c)
                snr = snr_err = k_ideal = None
                if dw_ideal is not None and ideal is not None:
                    k_ideal = float(np.sum(dw_ideal * np.asarray(ideal[c])[at]))
                    snr = detection.region_snr(k_ideal, masks[a], kernel_of(a), scale, norm=norms[a])
                    e_ideal = mc_error(dw_ideal, c, at)
                    if snr is not None and e_ideal is not None:
                        snr_err = e_ideal * norms[a] / scale
                pair[c] = {
                    "K": k,
                    "ideal_K": k_ideal,
                    "sigma": k / scale if sigma > 0 else float("nan"),
                    "stderr_K": err,
                    "truncation_bound_K": None if tb is None else tb * (2.0 if c == "I" else 1.0),
                    "snr": snr,
                    "snr_stderr": snr_err,
                    "detectable": detection.detectable(snr),
                    "pd": None if snr is None else detection.probability_of_detection(snr, pfa),
                }
                if err is not None and 2.0 * err > limit * (np.sqrt(2.0) if c == "I" else 1.0):
                    unsettled.append((f"{a} - {b_name}", c, err))
            contrasts[f"{a} - {b_name}"] = pair
            verdicts[f"{a} - {b_name}"] = detection.contrast_verdict(
                f"{a} - {b_name}", {c: (v["snr"], v["snr_stderr"], v["ideal_K"]) for c, v in pair.items()}
            )
    if unsettled:  # one line for all of them: each its pair, channel and standard error
        in_i = " (in I, sqrt(2) times that)" if any(c == "I" for _, c, _ in unsettled) else ""
        listed = "; ".join(f"{pair} in {c}: {err:.3g} K" for pair, c, err in unsettled)
        warn(
            f"output.regions: seeds will differ by more than {limit:.3g} K{in_i} in {len(unsettled)} "
            f"contrast{'s' if len(unsettled) > 1 else ''} by their Monte Carlo standard errors ({listed}); "
            "raise render.spp or set render.target_error"
        )
    return {
        "criterion": detection.CRITERION,
        "channel": report_channel(scn),
        "verdicts": verdicts,
        "false_alarm": pfa,
        "means": means,
        "pixels": pixels,
        "stderr": errors,
        "truncation": truncation,
        "contrasts": contrasts,
        "noise_K": sigma,
        "limit_K": limit,
    }


def truncation_summary(img: Image, scn: ScenarioConfig) -> dict:
    """Image-wide figures of the paths ended on a guessed temperature (`TileResult.truncated`)."""
    frac, b = img.truncated[..., 0], img.truncated[..., 1]
    return {
        "max_depth": scn.render.max_depth,
        "mean_fraction": float(frac.mean()),
        "max_fraction": float(frac.max()),
        "pixels_truncated": float((frac > 0).mean()),
        "mean_bound_K": float(b.mean()),
        "p99_bound_K": float(np.quantile(b, 0.99)),
        "max_bound_K": float(b.max()),
    }


def band_frequencies(f: float, bandwidth: float, n: int) -> list[float]:
    """Midpoints of n equal sub-bands of [f - B/2, f + B/2] (a flat spectral response); [f] if B = 0."""
    if bandwidth <= 0.0 or n <= 1:
        return [f]
    return [f - bandwidth / 2.0 + (k + 0.5) * bandwidth / n for k in range(n)]


def average_images(imgs: Sequence[Image]) -> Image:
    """Mean of images rendered at the sub-band frequencies (independent samples)."""
    from typing import cast

    from pmmw.trace.pool import Image

    # sum() starts from 0, and 0 + an array is the array: the sums of arrays are arrays
    n = len(imgs)
    return Image(
        cast(np.ndarray, sum(i.mean for i in imgs)) / n,
        np.sqrt(sum(i.stderr**2 for i in imgs)) / n,
        imgs[len(imgs) // 2].depth,
        imgs[len(imgs) // 2].material,
        cast(np.ndarray, sum(i.samples for i in imgs)).astype(np.int32),
        sum(i.rays for i in imgs),
        sum(i.t_isect for i in imgs),
        cast(np.ndarray, sum(i.truncated for i in imgs)) / n,
        cast(np.ndarray, sum(i.replicate_diff for i in imgs)) / n,
    )


def trace_frequency(
    res: Resolved,
    f: float,
    *,
    workers: int,
    tile_root: Path | None = None,
    shash: str = "",
    resume: bool = False,
    shard: tuple[int, int] | None = None,
    quiet: bool = True,
    client: Any = None,
) -> tuple[TraceJob | None, Image | None, list[Path]]:
    """Trace the image at frequency f [Hz], averaged over the imager's sub-bands.

    Tiles are kept in ``tile_root/<folder>/`` (`tile_folders`) when a root is given (resumable),
    nowhere otherwise. With ``shard=(i, n)`` only that shard's tiles are rendered and no image is made.
    With a Dask ``client`` the tiles are tasks on its cluster (`pool.render_tiles`).

    Returns
    -------
    job : TraceJob or None
        The job at f (None for a shard).
    img : Image or None
    tile_dirs : list of Path
    """
    scn = res.scenario
    imgs, dirs = [], []
    for fk, label, folder in tile_folders(scn, f, shash):
        job = make_job(res, fk)
        tile_dir = None if tile_root is None else tile_root / folder
        if tile_dir is not None:
            dirs.append(tile_dir)
            claim(tile_dir, tile_manifest(scn, shash), "--out")
        counts: dict = {}
        if shard is not None:
            mine = [t for t in job.tiles() if t[0] % shard[1] == shard[0] - 1]
            bar = _Progress(label, quiet)
            render_tiles(
                job,
                workers=workers,
                tile_dir=tile_dir,
                resume=True,
                progress=bar,
                tiles=mine,
                counts=counts,
                notify=bar.note,
            )
            say(
                f"{label}: shard {shard[0]}/{shard[1]}: {counts['rendered']} tiles rendered, {counts['reused']} "
                f"already there, in {tile_dir}; assemble with `pmmw render ... --resume` once every shard is done"
            )
            continue
        bar = _Progress(label, quiet)
        results = render_tiles(
            job,
            workers=workers,
            tile_dir=tile_dir,
            resume=resume,
            progress=bar,
            counts=counts,
            client=client,
            notify=bar.note,
        )
        if resume:
            say(f"{label}: --resume: {counts['reused']} tiles found, {counts['rendered']} rendered")
        imgs.append(assemble(job, results))
    if shard is not None:
        return None, None, dirs
    if len(imgs) == 1:
        return job, imgs[0], dirs
    return make_job(res, f), average_images(imgs), dirs


def receiver_of(scn: ScenarioConfig) -> Receiver | None:
    """The scenario's `imaging.receiver.Receiver`, or None without ``imager.receiver``."""
    rx, im = scn.imager.receiver, scn.imager
    if rx is None:
        return None
    # the schema's Receiver gives exactly one of noise_temperature and noise_figure, and one of
    # integration_time and frame_rate
    if rx.noise_temperature is not None:
        t_rec = rx.noise_temperature
    else:
        assert rx.noise_figure is not None
        t_rec = noise_temperature(rx.noise_figure)
    if rx.integration_time is not None:
        tau = rx.integration_time
    else:
        assert rx.frame_rate is not None
        per = rx.pixels_per_receiver or -(-im.resolution[0] * im.resolution[1] // rx.receivers)
        tau = dwell_time(rx.frame_rate, per)
    return Receiver(
        t_rec=t_rec,
        bandwidth=rx.bandwidth if rx.bandwidth is not None else im.bandwidth,
        tau=tau,
        mode=rx.mode,
        gain_fluctuation=rx.gain_fluctuation,
        t_ref=rx.reference_temperature,
    )


def aperture_of(scn: ScenarioConfig) -> Aperture | None:
    """The scenario's `imaging.antenna.Aperture` (a uniform one without ``imager.antenna``), or
    None without an aperture."""
    im = scn.imager
    if not im.aperture_diameter > 0:
        return None
    a = im.antenna
    if a is None:
        return Aperture()
    spill = (
        a.spillover
        if a.spillover is not None
        else (
            gaussian_feed_spillover(a.edge_taper) if a.illumination == "gaussian" and a.edge_taper is not None else 0.0
        )
    )
    return Aperture(
        kind=a.illumination,
        edge_taper_db=a.edge_taper or 0.0,
        blockage=a.blockage,
        spillover=spill,
        spillover_temperature=a.spillover_temperature,
    )


def imager_kernel(scn: ScenarioConfig, pixel_angle: float, k0: float, cache: dict | None = None) -> np.ndarray | None:
    """The imager's unit-sum PSF kernel at wavenumber ``k0`` [1/m] on pixels of ``pixel_angle``
    [rad]: the antenna's (`imaging.antenna.antenna_kernel`) with ``imager.antenna``, else the
    uniform aperture's Airy kernel (`imaging.imager.psf_kernel`); None without an aperture. The one
    kernel the imager model blurs with and adaptive sampling sizes its error target by.

    ``cache`` (`Resolved.kernels`): kernels made before, keyed by all the kernel depends on (pixel
    pitch, wavenumber, aperture diameter, the whole aperture model `Aperture`); a kernel found
    there is not computed again. Nothing is evicted: it holds one kernel per distinct set. Each caller gets its own copy.
    """
    im = scn.imager
    if not im.aperture_diameter > 0.0:
        return None
    aperture = aperture_of(scn) if im.antenna is not None else None
    key = (float(pixel_angle), float(k0), float(im.aperture_diameter), aperture)
    kernel = None if cache is None else cache.get(key)
    if kernel is None:
        if aperture is not None:
            kernel = antenna_kernel(pixel_angle, k0, im.aperture_diameter, aperture)
        else:
            kernel = psf_kernel(pixel_angle, k0, im.aperture_diameter)
        if cache is not None:
            cache[key] = kernel
    return kernel.copy()


def imager_model(
    scn: ScenarioConfig,
    job: TraceJob,
    ideal: dict,
    noise_maps: dict | None = None,
    kernels: dict | None = None,
) -> tuple[dict[str, np.ndarray], np.ndarray | None]:
    """The sensor image (`apply_imager` with the scenario's aperture, antenna, noise or receiver and
    seed) and the PSF kernel of the scene's signal: the unit-sum PSF times (1 - spillover) (None
    without an aperture). ``noise_maps`` is filled with the per-pixel noise of each channel when
    the imager has a receiver; ``kernels``: the PSF kernels made before (`imager_kernel`)."""
    im = scn.imager
    ap = aperture_of(scn) if im.antenna is not None else None
    kernel = imager_kernel(scn, job.camera.pixel_angle, job.k0, kernels)
    spill = ap.spillover if ap is not None else 0.0
    field = field_psf_of(scn, job, kernels) if ap is not None else None
    sensor = apply_imager(
        ideal,
        pixel_angle=job.camera.pixel_angle,
        k0=job.k0,
        aperture_diameter=im.aperture_diameter,
        noise=im.noise,
        seed=scn.render.seed,
        kernel=kernel,
        spillover=spill,
        spillover_temperature=ap.spillover_temperature if ap is not None else 0.0,
        receiver=receiver_of(scn),
        noise_maps=noise_maps,
        field_psf=field,
    )
    return sensor, (None if kernel is None else kernel * (1.0 - spill))


def field_psf_of(scn: ScenarioConfig, job: TraceJob, cache: dict | None = None) -> FieldPSF | None:
    """The field-dependent blur (`imaging.antenna.FieldPSF`) of ``imager.antenna.off_axis:
    projected``, else None (one PSF over the image); kept in ``cache`` (`Resolved.kernels`) with
    the kernels it depends on, as `imager_kernel` keeps its own."""
    im = scn.imager
    if im.antenna is None or im.antenna.off_axis != "projected" or not im.aperture_diameter > 0.0:
        return None
    cam = job.camera
    aperture = aperture_of(scn)
    assert aperture is not None  # an aperture diameter > 0 has one
    key = (
        "field",
        float(cam.pixel_angle),
        float(job.k0),
        float(im.aperture_diameter),
        aperture,
        cam.width,
        cam.height,
        float(cam.fov),
    )
    field = None if cache is None else cache.get(key)
    if field is None:
        field = FieldPSF(cam.pixel_angle, job.k0, im.aperture_diameter, aperture, cam.width, cam.height, cam.fov)
        if cache is not None:
            cache[key] = field
    return field


def region_kernels(
    scn: ScenarioConfig, job: TraceJob, kernel: np.ndarray | None, cache: dict | None = None
) -> dict[str, np.ndarray | None] | None:
    """Each region's own PSF when the beam depends on the field (``imager.antenna.off_axis:
    projected``): the beam at the centre of the region's pixels (`FieldPSF.kernel_at`), scaled as
    ``kernel`` is (its sum: 1 - spillover); None when one PSF serves the whole image. A region's
    detection (`region_stats`) then uses the beam its target is seen through."""
    field = field_psf_of(scn, job, cache)
    if field is None or kernel is None or not scn.output.regions:
        return None
    out: dict[str, np.ndarray | None] = {}
    for name, mask in region_masks(scn.output.regions, job.camera).items():
        rows, cols = np.nonzero(mask)
        out[name] = field.kernel_at(rows.mean(), cols.mean()) * float(kernel.sum()) if rows.size else None
    return out


def imager_summary(scn: ScenarioConfig, job: TraceJob | SimpleNamespace, noise_maps: dict | None = None) -> dict:
    """What a report states about the imager: ``receiver`` (NETD, per-pixel noise range:
    `imaging.receiver.Receiver.summary`) and ``beam`` (`imaging.antenna.beam_report`), each when
    the imager has it."""
    out = {}
    rx = receiver_of(scn)
    if rx is not None:
        out["receiver"] = rx.summary(noise_maps)
    ap = aperture_of(scn)
    if ap is not None:
        out["beam"] = beam_report(ap, job.k0, scn.imager.aperture_diameter, job.camera.pixel_angle)
        if scn.imager.antenna is not None and scn.imager.antenna.off_axis == "projected":
            cam = job.camera
            tc = float(pixel_field_angles(cam.width, cam.height, cam.fov)[0].max())
            ka = job.k0 * scn.imager.aperture_diameter / 2.0
            u_half = ka * np.sin(out["beam"]["hpbw_mrad"] / 2e3)  # the on-axis half-power point (its u)
            out["beam"]["off_axis"] = {
                "model": "projected aperture",
                "corner_field_angle_deg": float(np.degrees(tc)),
                "corner_hpbw_radial_mrad": 2e3 * float(np.arcsin(min(1.0, u_half / (ka * np.cos(tc))))),
                "corner_hpbw_tangential_mrad": out["beam"]["hpbw_mrad"],
            }
        if out["beam"]["pitch_over_nyquist"] > 1.0 + 1e-9:
            out["beam"]["sampling"] += (
                f" ({out['beam']['pitch_over_nyquist']:.3g} x the Nyquist pitch: "
                "raise imager.resolution or narrow imager.fov to sample the beam)"
            )
    return out


def _stem(scn: ScenarioConfig, f: float) -> str:
    return scn.name if len(scn.frequencies) == 1 else f"{scn.name}_{f / 1e9:g}GHz"


def preview_channels(scn: ScenarioConfig) -> tuple[str, ...]:
    """The channels a render writes a plain preview of (`io.preview.write_preview`): with
    ``output.previews: true`` (the default, or ``all``, or ``figures``) every channel of
    ``output.channels``, a PNG preview per channel as the product promises; with ``quick`` I alone
    (the first channel listed where I is not), the image a person reads first and the one
    `pmmw sweep`'s contact sheet and the Blender add-on show; none with ``false``."""
    chans, on = scn.output.channels, scn.output.previews
    if on is True or on in ("all", "figures"):
        return tuple(chans)
    if not on:
        return ()
    return ("I",) if "I" in chans else tuple(chans[:1])


def output_names(scn: ScenarioConfig, f: float) -> dict:
    """The files a render writes for frequency f [Hz], relative to the output folder: ``exr``;
    ``previews`` (channel -> the plain PNG: `preview_channels`); ``regions_preview`` (``regions``
    -> PNG: the sensor image with ``output.regions`` outlined, when there are regions and any
    preview); with ``output.previews: figures`` also the matplotlib figures: ``figures`` (channel
    -> the channel with its colour bar), ``side_by_side`` (channel -> the ideal image beside the
    sensor's, when the imager changes something), ``aux_previews`` (``depth``, ``material`` ->
    PNG, when ``output.aux`` asks for them), the regions preview then naming the regions;
    ``reports`` (JSON, Markdown)."""
    stem = _stem(scn, f)
    chans = scn.output.channels
    on = scn.output.previews
    figures = on == "figures"
    side = ("Ex2", "Ey2") if "Ex2" in chans else chans[:1]
    if scn.imager.aperture_diameter <= 0 and scn.imager.noise <= 0:
        side = ()  # the sensor image is the ideal one: no pair to compare
    suffix = "" if len(scn.frequencies) == 1 else f"_{f / 1e9:g}GHz"
    return {
        "exr": f"{stem}.exr",
        "previews": {c: f"previews/{stem}_{c}.png" for c in preview_channels(scn)},
        "figures": {c: f"previews/{stem}_{c}_figure.png" for c in chans} if figures else {},
        "side_by_side": {c: f"previews/{stem}_{c}_ideal_sensor.png" for c in side} if figures else {},
        "aux_previews": {a: f"previews/{stem}_{a}.png" for a in ("depth", "material") if a in scn.output.aux}
        if figures
        else {},
        "regions_preview": {"regions": f"previews/{stem}_regions.png"} if on and scn.output.regions else {},
        "reports": [f"report{suffix}.json", f"report{suffix}.md"],
    }


def _imager_words(scn: ScenarioConfig) -> str:
    im = scn.imager
    parts = ([f"{im.aperture_diameter:g} m aperture"] if im.aperture_diameter > 0 else []) + (
        [f"{im.noise:g} K noise"] if im.noise > 0 else []
    )
    return ", ".join(parts) or "ideal"


def _all_outputs(names: dict) -> list[str]:
    return [
        names["exr"],
        *names["previews"].values(),
        *names["figures"].values(),
        *names["side_by_side"].values(),
        *names["aux_previews"].values(),
        *names["regions_preview"].values(),
        *names["reports"],
    ]


# [s] per camera path per core: the shipped landing scene on a 2-core laptop (docs/benchmarks.md);
# refracting and rough scenes take several times longer
SECONDS_PER_PATH = 1e-5
TILE_BYTES_PER_PIXEL = 17 * 8  # float64 fields of a TileResult per pixel (pool._save_tile)
# Memory of a render [bytes]: measured peaks (the sum of the proportional set sizes of the parent
# and its workers, a 1e6-triangle OBJ on 2 workers; `tests/reliability/test_reliability_bounds.py` checks the
# estimate against a measured render) with a margin.
PARENT_BASE_BYTES = 250e6  # the parent: interpreter, numpy, trimesh, the compiled kernels (238 MB measured)
WORKER_BASE_BYTES = 250e6  # a render worker: interpreter, numpy, Embree, one wave of MAX_WAVE rays
# the scene in the parent: vertices (24 B each, up to 3 a triangle), faces, normals (24 each), material,
# object, medium (4 each); 73 measured after reading an OBJ (a shared-vertex grid), 129 an STL (a soup)
PARENT_BYTES_PER_TRIANGLE = 160
# the peak of reading a mesh in the parent, before any worker starts: 612 measured (OBJ), 822 (STL)
LOAD_BYTES_PER_TRIANGLE = 1000
# a worker's own copy of the scene: the intersector's per-face arrays (113 B) and Embree's
# triangles and BVH; 447 measured (forked: what the worker shares with the parent is counted once)
WORKER_BYTES_PER_TRIANGLE = 600


def estimate_resources(scn: ScenarioConfig, triangles: int, workers: int) -> dict:
    """Memory, disk and time a render of ``scn`` needs, from its size (upper bounds, except the
    time, which is a rough guide for landing-like scenes).

    Memory: every copy counted, whichever is larger of the mesh's reading (the parent alone,
    `LOAD_BYTES_PER_TRIANGLE`, before the workers start) and the render: the parent holds the
    scene (`PARENT_BYTES_PER_TRIANGLE`), the sky texture (its float64 maps and the next sub-band's
    being read, `sky_texture.LOAD_BYTES_PER_PIXEL`), each frequency's tiles, its sub-band images
    and the output channels (~136 B per pixel per image); each worker its own copy of the scene
    (`WORKER_BYTES_PER_TRIANGLE`) and one wave of rays, which the integrator bounds (`MAX_WAVE`),
    so it does not grow with spp. Disk: the resumable tiles (~136 B per pixel per sub-band) and
    the EXR (4 B per channel per pixel, uncompressed bound).
    """
    w, h = scn.imager.resolution
    px = w * h
    bands = scn.imager.band_samples if scn.imager.bandwidth > 0 else 1
    nf = len(scn.frequencies)
    n_chan = 2 * len(scn.output.channels) + 6
    paths = px * scn.render.spp * bands * nf
    parent = (
        PARENT_BASE_BYTES
        + px * (TILE_BYTES_PER_PIXEL * (bands + 2) + 12 * n_chan)
        + PARENT_BYTES_PER_TRIANGLE * triangles
        + _sky_texture_bytes(scn)
    )
    worker = WORKER_BASE_BYTES + WORKER_BYTES_PER_TRIANGLE * triangles
    load = PARENT_BASE_BYTES + LOAD_BYTES_PER_TRIANGLE * triangles
    return {
        "pixels": px,
        "camera_paths_at_most": paths,
        "memory_bytes": int(max(load, parent + max(1, workers) * worker)),
        "disk_bytes": int(px * (TILE_BYTES_PER_PIXEL * bands + 4 * n_chan) * nf),
        "time_s_rough": paths * SECONDS_PER_PATH / max(1, workers),
    }


def _sky_texture_bytes(scn: ScenarioConfig) -> float:
    """Memory of the scenario's sky texture in the parent [bytes], from its header: the float64
    maps of one sub-band's sky and the next one's being read (shared with forked workers)."""
    if scn.sky.model != "texture" or not scn.sky.file:
        return 0.0
    from pmmw.io.exr import READ_BYTES_PER_SAMPLE, image_size
    from pmmw.scene import sky_texture

    try:
        w, h, _ = image_size(scn.sky.file, key="sky.file")
    except UserError:  # reported when the sky is made
        return 0.0
    read = READ_BYTES_PER_SAMPLE // 2 * len(sky_texture.SKY_CHANNELS)  # its two channels, read by name
    per_pixel = sky_texture.BYTES_PER_PIXEL + sky_texture.LOAD_BYTES_PER_PIXEL + read
    return float(w) * h * per_pixel


def available_memory() -> float | None:
    """Memory the system can give without swapping [bytes] (Linux MemAvailable), or None."""
    from pmmw import memory

    return memory.available_memory()


def check_memory(est: dict, source: str | Path | None, force: bool = False) -> None:
    """Refuse (`UserError`, exit status 2 as every input sized beyond its limit: `memory`) a
    render whose estimate `est` exceeds the available memory, unless ``force``."""
    free = available_memory()
    if free is not None and est["memory_bytes"] > free and not force:
        raise UserError(
            f"the render needs about {est['memory_bytes'] / 1e9:.3g} GB of memory and {free / 1e9:.3g} GB are "
            "available: lower imager.resolution or render.workers (or pass --force to try anyway)",
            file=source,
        )


def tile_manifest(scn: ScenarioConfig, shash: str) -> dict:
    """What a tile folder of ``scn`` records (`io.tilestore.claim`): the scenario's name, the
    hash of its traced settings and inputs, the version and the settings themselves."""
    return {"name": scn.name, "hash": shash, "version": __version__, "scenario": traced_settings(scn)}


def tile_folders(scn: ScenarioConfig, f: float, shash: str) -> list[tuple[float, str, str]]:
    """(sub-band frequency [Hz], progress label, tile folder name) of each sub-band traced for the
    frequency f [Hz]. Folder names are ``<stem>-<hash>`` or ``<stem>@band<k>of<n>-<hash>``: a name
    cannot hold ``@`` nor end like a frequency suffix (`config.schema`), so no scenario's folder
    name can be another's."""
    stem = _stem(scn, f)
    bands = band_frequencies(f, scn.imager.bandwidth, scn.imager.band_samples)
    if len(bands) == 1:
        return [(bands[0], stem, f"{stem}-{shash}")]
    return [
        (fk, f"{stem}@{fk / 1e9:.6g}GHz", f"{stem}@band{k + 1}of{len(bands)}-{shash}") for k, fk in enumerate(bands)
    ]


def other_tile_folders(tile_root: Path, scn: ScenarioConfig, shash: str) -> list[tuple[Path, dict]]:
    """(folder, manifest) of the pmmw tile folders of this scenario (by its name) made from other
    inputs (another hash)."""
    return [(d, rec) for d, rec in own_folders(tile_root) if rec.get("name") == scn.name and rec["hash"] != shash]


def _differences(a: object, b: object, prefix: str = "") -> list[str]:
    """Dotted keys whose values differ between two display dicts, as ``key: old -> new``."""
    out = []
    if isinstance(a, dict) and isinstance(b, dict):
        for k in sorted(set(a) | set(b), key=str):
            out += _differences(a.get(k), b.get(k), f"{prefix}.{k}" if prefix else str(k))
    elif a != b:
        out.append(f"{prefix}: {a!r} -> {b!r}")
    return out


def refuse_other_tiles(tile_root: Path, scn: ScenarioConfig, shash: str, what: str) -> None:
    """Tiles of this scenario made with other settings are never mixed in nor silently
    re-rendered over: name the folder and the settings that differ."""
    for d, old in other_tile_folders(tile_root, scn, shash):
        if not any(d.glob("tile_*.npz")):
            continue
        now = traced_settings(scn)
        diff = _differences(
            json.loads(json.dumps(old.get("scenario"), default=str)), json.loads(json.dumps(now, default=str))
        )
        if old.get("version") != __version__:
            diff.append(f"pmmw version: {old.get('version')} -> {__version__}")
        why = "; ".join(diff[:6]) or "the same settings but other input files (a mesh, texture or material changed)"
        raise UserError(
            f"{d.name} holds tiles of this scenario rendered from other inputs ({why}); run every "
            "shard with the same scenario, or render without --resume to start afresh (which "
            "deletes them)",
            file=what,
        )


def remove_stale_tiles(tile_root: Path, out_dir: Path, scn: ScenarioConfig, shash: str) -> tuple[int, int]:
    """Delete the tile folders of this scenario made from other inputs (another hash): they can
    never be resumed. Only pmmw's own folders inside the real output folder are deleted
    (`io.tilestore.remove_folder`). Returns (removed, kept)."""
    stale = [d for d, _ in other_tile_folders(tile_root, scn, shash)]
    removed = sum(remove_folder(d, out_dir) for d in stale)
    return removed, len(stale) - removed


def render(
    path: str | Path,
    overrides: Sequence[str] = (),
    *,
    out: str | Path | None = None,
    spp: int | None = None,
    workers: int | None = None,
    seed: int | None = None,
    resume: bool = False,
    quiet: bool = False,
    keep_tiles: bool = False,
    shard: tuple[int, int] | None = None,
    force: bool = False,
    executor: str = "local",
    scheduler: str | None = None,
    cluster: str | Path | None = None,
    data: dict | None = None,
    values: dict | None = None,
) -> list[Path]:
    """The ``pmmw render`` job. Returns the EXR paths written.

    With ``shard=(i, n)`` only tiles whose index is i modulo n are rendered into the tile folder
    and no image is written: run the n shards anywhere that shares the output folder, then run
    once more with ``resume=True`` (and no shard) to assemble the image.

    Before tracing, the outputs are checked (`check_outputs`: writable, no input overwritten,
    names that fit, room on the disk) and memory is estimated (`estimate_resources`); ``force``
    renders past the memory and disk estimates. Each frequency's EXR, previews and reports are
    staged and moved into place together (`Staging`), reports last.

    ``executor="dask"`` renders the tiles as tasks on a Dask cluster (`distributed.connect`: the
    job-queue cluster of the file ``cluster``, the scheduler at ``scheduler``, or a local one of
    ``workers`` processes) and assembles the image here; the tiles are the same, so is the image.
    """
    from pmmw.distributed import EXECUTORS

    if executor not in EXECUTORS:
        raise UserError(f"expected one of {', '.join(EXECUTORS)}, got {executor!r}", "--executor")
    if executor == "local" and (scheduler or cluster):
        executor = "dask"
    if executor == "dask" and shard is not None:
        raise UserError(
            "--shard splits a render into separate jobs; with --executor dask the cluster renders "
            "every tile of one job: use one or the other",
            "--shard",
        )
    if executor == "dask" and scheduler and cluster is None:  # a wrong address told before the scene loads
        from pmmw.distributed import probe_scheduler

        probe_scheduler(scheduler)
    clear_warnings()
    t0 = time.perf_counter()
    cli = {k: v for k, v in (("spp", spp), ("workers", workers), ("seed", seed), ("out", out)) if v is not None}
    with timings.phase("resolve"):
        res = resolve(path, overrides, cli=cli, data=data, values=values)
    scn = res.scenario
    out_dir = Path(scn.output.dir) if scn.output.dir is not None else Path.cwd() / "out" / scn.name
    n_workers = scn.render.workers or default_workers()
    est = estimate_resources(scn, int(res.geometry.faces.shape[0]), n_workers)
    names = {f: output_names(scn, f) for f in scn.frequencies}
    inputs = input_files(scn)
    where = "output.dir" if out is None else "--out"
    check_outputs(
        out_dir,
        [n for f in scn.frequencies for n in _all_outputs(names[f])],
        inputs,
        key=where,
        disk_bytes=est["disk_bytes"],
        force=force,
        scenario_name=scn.name,
    )
    check_memory(est, scn.source_file, force)
    shash = scenario_hash(scn, res.db, inputs)
    tile_root = out_dir / TILE_ROOT
    with FolderLock(out_dir, mode="write" if shard is None else "shard", what=where) as lock:
        remove_stale_staging(out_dir)
        if resume or shard is not None:
            refuse_other_tiles(tile_root, scn, shash, "--resume" if shard is None else f"--shard {shard[0]}/{shard[1]}")
        elif deletable(tile_root, out_dir):
            removed, kept = remove_stale_tiles(tile_root, out_dir, scn, shash)
            if removed and not quiet:
                say(
                    f"removed {removed} tile folder(s) of an earlier version of this scenario (other inputs: never "
                    "resumable)"
                )
            if kept:
                warn(
                    f"kept {kept} tile folder(s) of an earlier version of this scenario in {tile_root}: they hold "
                    "files pmmw did not write"
                )
        for f in scn.frequencies:  # every tile folder checked before the first ray
            for _, _, folder in tile_folders(scn, f, shash):
                claim(tile_root / folder, tile_manifest(scn, shash), where)
        t_resolve = time.perf_counter() - t0
        timings.mark("outputs checked")
        written, tile_dirs = _render_and_commit(
            res,
            names,
            out_dir,
            tile_root,
            shash,
            lock,
            t0,
            t_resolve,
            n_workers=n_workers,
            resume=resume,
            shard=shard,
            quiet=quiet,
            executor=executor,
            scheduler=scheduler,
            cluster=cluster,
        )
        if written and not keep_tiles:  # only once every output is in place: until then tiles resume
            if deletable(tile_root, out_dir):
                with timings.phase("tiles removed"):
                    for d in tile_dirs:
                        remove_folder(d, out_dir)
                    remove_root_if_empty(tile_root, out_dir)
            else:
                say(
                    f"tiles kept in {tile_root}: it links out of the output folder, and pmmw never deletes "
                    "through a link"
                )
    return written


def _render_and_commit(
    res,
    names,
    out_dir,
    tile_root,
    shash,
    lock,
    t0,
    t_resolve,
    *,
    n_workers,
    resume,
    shard,
    quiet,
    executor,
    scheduler,
    cluster,
):
    """Trace every frequency of the resolved scenario, then stage its outputs and commit them
    (reports last) while ``lock`` is still this run's. Returns (EXRs written, tile folders)."""
    scn = res.scenario
    written, renders, tile_dirs = [], [], []
    client = None
    with contextlib.ExitStack() as staging:  # staged outputs are deleted on the way out, committed or not
        if executor == "dask":
            from pmmw.distributed import dask_client

            client = staging.enter_context(dask_client(scheduler, cluster, n_workers))
        for f in scn.frequencies:
            t1 = time.perf_counter()
            tiles_before = timings.recorded()[1].get(TILES, 0.0)
            try:
                with timings.phase("trace"):
                    job, img, dirs = trace_frequency(
                        res,
                        f,
                        workers=n_workers,
                        tile_root=tile_root,
                        shash=shash,
                        resume=resume,
                        shard=shard,
                        quiet=quiet,
                        client=client,
                    )
            except OSError as e:  # saving tiles: disk full, quota, a folder gone read-only
                raise os_problem(e, tile_root, "save the finished tiles") from None
            tile_dirs += dirs
            if job is None or img is None:  # a shard (both None)
                continue
            t_trace = time.perf_counter() - t1
            t_tiles = timings.recorded()[1].get(TILES, 0.0) - tiles_before  # the tiles alone (`trace.pool.TILES`)
            staged = staging.enter_context(Staging(out_dir))
            renders.append(
                (staged, _finish_frequency(res, f, job, img, names[f], staged, shash, t_trace, n_workers, t_tiles))
            )
            written.append(out_dir / names[f]["exr"])
        total = time.perf_counter() - t0
        band = materials_band(res) if renders else {}
        for staged, r in renders:
            report = {
                "name": _stem(scn, r["frequency_hz"]),
                "version": __version__,
                **r,
                "timing": {"resolve_s": round(t_resolve, 3), **r["timing"], "total_s": round(total, 3)},
                "materials_band": band,
                "warnings": collected_warnings(),
                "scenario": scenario_to_display(scn),
            }
            reports = names[r["frequency_hz"]]["reports"]
            with timings.phase("report"):
                try:
                    with synced_together():
                        write_report(staged.root, report, r["previews"], basename=Path(reports[0]).stem)
                except OSError as e:
                    raise os_problem(e, out_dir, "write the report") from None
            with timings.phase("outputs moved into place"):
                staged.commit(_all_outputs(names[r["frequency_hz"]])[: -len(reports)], last=reports, check=lock.check)
            say(
                f"{report['name']}: {r['pixels']} px x {spp_words(r['spp'], r['mean_samples_per_pixel'])}, "
                f"{r['rays'] / 1e6:.2f} M rays, "
                f"{r['timing']['tiles_s']:.1f} s trace, {total:.1f} s total -> {r['output_exr']}",
                result=True,
            )
    return written, tile_dirs


def spp_words(spp: int, mean: float) -> str:
    """The samples per pixel of the render summary: ``256 spp``, or the mean actually averaged
    when adaptive sampling (``render.target_error``) stopped early, e.g. ``9.8 spp averaged
    (adaptive, up to 256)``."""
    if mean < spp - 0.05:
        return f"{mean:.3g} spp averaged (adaptive, up to {spp})"
    return f"{spp} spp"


def frequency_images(
    scn: ScenarioConfig, f: float, job: TraceJob, img: Image, shash: str = "", kernels: dict | None = None
) -> dict:
    """The images of one frequency from its traced ``img``: ``ideal`` and ``sensor`` (Stokes and
    polarization channels [K], float64), the PSF ``kernel`` (and each region's, ``region_kernels``,
    when the beam depends on the field), and what the EXR holds: ``channels``
    (float32: the sensor's, ``ideal.*``, ``aux.*``) with its header ``attrs``. ``kernels``: the
    PSF kernels made before (`Resolved.kernels`)."""
    ideal = stokes_images(img.mean)
    noise_maps: dict[str, np.ndarray] = {}
    kernels = {} if kernels is None else kernels  # the field-dependent beam is made once, for both uses
    sensor, kernel = imager_model(scn, job, ideal, noise_maps, kernels)
    if not all(np.isfinite(sensor[c]).all() for c in scn.output.channels):
        raise RuntimeError(f"non-finite pixels in the {f / 1e9:g} GHz image: a bug, please report it")
    channels = {c: sensor[c].astype(np.float32) for c in scn.output.channels}
    channels.update({f"ideal.{c}": ideal[c].astype(np.float32) for c in scn.output.channels})
    channels.update(aux_channels(img, scn.output.aux))
    cam = job.camera
    attrs = {
        "pmmw:version": __version__,
        "pmmw:units": "K (Rayleigh-Jeans brightness temperature)",
        "pmmw:frequency_hz": float(f),
        "pmmw:fov_deg": float(np.degrees(cam.fov)),
        "pmmw:resolution": f"{cam.width}x{cam.height}",
        "pmmw:imager_position_m": " ".join(f"{v:g}" for v in cam.position),
        "pmmw:imager_x": " ".join(f"{v:.9g}" for v in cam.x),
        "pmmw:imager_y": " ".join(f"{v:.9g}" for v in cam.y),
        "pmmw:imager_k": " ".join(f"{v:.9g}" for v in cam.k),
        "pmmw:scenario": str(scn.source_file),
        "pmmw:scenario_hash": shash,
        "pmmw:spp": int(scn.render.spp),
        "pmmw:seed": int(scn.render.seed),
        "pmmw:convention": "x right, y up, k viewing; I=Ex2+Ey2, Q=Ex2-Ey2, U=2Re(ExEy*), V=2Im(ExEy*) (Murakowski 2014 eq. 2.12)",
        "pmmw:materials": ",".join(job.media.ids),
    }
    return {
        "ideal": ideal,
        "sensor": sensor,
        "kernel": kernel,
        "region_kernels": region_kernels(scn, job, kernel, kernels),
        "channels": channels,
        "attrs": attrs,
        "noise_maps": noise_maps or None,
    }


def _finish_frequency(
    res: Resolved,
    f: float,
    job: TraceJob,
    img: Image,
    names: dict,
    staged: Staging,
    shash: str,
    t_trace: float,
    n_workers: int,
    t_tiles: float = 0.0,
) -> dict:
    """Imager model, EXR and previews of one frequency, written into ``staged``; returns the
    frequency's report entry (the caller adds the report and commits them together). ``t_trace``
    [s] is the whole trace (the job, the kernels loaded or compiled, the tiles), ``t_tiles`` the
    tiles' tracing alone: the report's ``timing.trace_s`` and ``timing.tiles_s``."""
    scn = res.scenario
    t1 = time.perf_counter()
    with timings.phase("imager model"):
        images = frequency_images(scn, f, job, img, shash, res.kernels)
        summary = imager_summary(scn, job, images["noise_maps"])
    ideal, sensor, kernel = images["ideal"], images["sensor"], images["kernel"]
    cam = job.camera
    with timings.phase("region statistics"):
        regions = (
            region_stats(scn, cam, sensor, img, images["region_kernels"] or kernel, ideal, images["noise_maps"])
            if scn.output.regions
            else None
        )
    try:
        with synced_together():  # each file's fsync at the end, all at once
            with timings.phase("EXR"):
                write_exr(
                    staged.path(names["exr"]), images["channels"], images["attrs"], compression=scn.output.compression
                )
            with timings.phase("previews"):
                shown = write_previews(scn, f, job, img, names, staged.path, sensor, ideal, regions)
    except OSError as e:
        raise os_problem(e, staged.out_dir, "write the image") from None
    with timings.phase("channel statistics"):
        stats = {}
        for c in scn.output.channels:
            chan = sensor[c]
            stats[c] = {"min": float(np.min(chan)), "mean": float(np.mean(chan)), "max": float(np.max(chan))}
            if c in shown:
                stats[c].update(display_low=shown[c][0], display_high=shown[c][1])
        truncation = truncation_summary(img, scn)
        atmosphere = atmosphere_summary(job) if job.atmosphere is not None else None
    t_total = time.perf_counter() - t1 + t_trace
    return {
        "truncation": truncation,
        **({"imager": summary} if summary else {}),
        **({"figures": dict(names["figures"])} if names["figures"] else {}),
        **({"side_by_side": dict(names["side_by_side"])} if names["side_by_side"] else {}),
        **({"regions": regions} if regions else {}),
        **({"atmosphere": atmosphere} if atmosphere is not None else {}),
        "frequency_hz": f,
        "output_exr": str(staged.out_dir / names["exr"]),
        "channels": stats,
        "previews": {**names["previews"], **{f"aux.{a}": rel for a, rel in names["aux_previews"].items()}},
        **({"regions_preview": names["regions_preview"]["regions"]} if names["regions_preview"] else {}),
        **(
            {"regions_outlines": region_colour_names(scn.output.regions)}
            if names["regions_preview"] and scn.output.previews != "figures"
            else {}
        ),
        "rays": img.rays,
        "timing": {
            "trace_s": round(t_trace, 3),
            "tiles_s": round(t_tiles, 3),
            "intersect_s": round(img.t_isect, 3),
            "frequency_total_s": round(t_total, 3),
        },
        "mean_samples_per_pixel": float(img.samples.mean()),
        "workers": n_workers,
        "pixels": cam.width * cam.height,
        "spp": scn.render.spp,
    }


def write_previews(
    scn: ScenarioConfig,
    f: float,
    job: TraceJob,
    img: Image,
    names: dict,
    path_of: Callable[[str], Path],
    sensor: Mapping[str, np.ndarray],
    ideal: Mapping[str, np.ndarray],
    regions: dict | None,
) -> dict:
    """Write the previews ``names`` asks for (`output_names`) of one frequency's images at
    ``path_of(relative name)``: the plain PNGs (`io.preview.write_preview`, the regions
    outlined by `io.preview.write_regions_png`) and, with ``output.previews: figures``, the
    matplotlib figures. Returns {channel: (low, high)}: the temperatures [K] shown as black and
    white in each channel's plain preview."""
    shown = {c: write_preview(path_of(rel), sensor[c]) for c, rel in names["previews"].items()}
    label = f"{_stem(scn, f)}: {{}}, {f / 1e9:g} GHz"
    if names["regions_preview"]:
        assert regions is not None  # a regions preview is named for a scenario with regions
        c = regions["channel"]
        rel = names["regions_preview"]["regions"]
        if scn.output.previews == "figures":
            first = next(iter(regions["verdicts"].values()), None)
            write_regions_figure(
                path_of(rel),
                sensor[c],
                region_shapes(scn.output.regions, job.camera),
                title=label.format(f"{c}, regions"),
                caption=first,
            )
        else:
            write_regions_png(path_of(rel), sensor[c], region_masks(scn.output.regions, job.camera))
    for c, rel in names["figures"].items():
        write_figure(path_of(rel), [(None, sensor[c])], title=label.format(c))
    for c, rel in names["side_by_side"].items():  # each on its own range: the ideal's structure readable
        write_figure(
            path_of(rel),
            [("ideal (before the imager)", ideal[c]), (f"sensor ({_imager_words(scn)})", sensor[c])],
            title=label.format(c),
        )
    if "depth" in names["aux_previews"]:
        write_depth_figure(path_of(names["aux_previews"]["depth"]), img.depth, title=label.format("depth"))
    if "material" in names["aux_previews"]:
        write_material_figure(
            path_of(names["aux_previews"]["material"]),
            img.material,
            job.media.ids,
            title=label.format("material of the first hit"),
        )
    return shown


def materials_band(res: Resolved) -> dict:
    """Where the scene's materials are all inside their stated ranges (`stated_band` over the
    frequencies a scenario accepts), and each material that limits it: what `pmmw validate` and the
    render's report say."""
    scn = res.scenario
    band, limits = stated_band(res.db, res.geometry.material_ids, scn.render.default_temperature, FREQUENCY_RANGE)
    return {
        "within_stated_ranges": band_text(band),
        "accepted": band_text([FREQUENCY_RANGE]),
        "limited_by": {k: band_text(v) for k, v in limits.items()},
        "intervals_hz": [[lo, hi] for lo, hi in band],  # the same, for programs (`sweeps.run`)
        "limited_by_hz": {k: [[lo, hi] for lo, hi in v] for k, v in limits.items()},
    }


def validate(
    path: str | Path,
    overrides: Sequence[str] = (),
    data: dict | None = None,
    values: dict | None = None,
    preview: str | Path | None = None,
) -> dict:
    """The ``pmmw validate`` job: the resolved scenario and, per frequency, the media (and the slab
    sky's opacity and brightness, defaults included), the geometry and the resources. With
    ``preview`` (a PNG path) also the view's distance map with the regions outlined and named
    (`view_preview`)."""
    clear_warnings()
    res = resolve(path, overrides, data=data, values=values)
    scn, geom = res.scenario, res.geometry
    if preview is not None:
        view_preview(scn, geom, Path(preview))
    per_object = {}
    for i, (name, entry) in enumerate(zip(geom.objects, scn.scene)):
        v = geom.vertices[np.unique(geom.faces[geom.face_object == i])]
        per_object[name] = {
            "bounds_m": [[round(float(x), 4) for x in v.min(axis=0)], [round(float(x), 4) for x in v.max(axis=0)]],
            "file_up_axis": file_up_axis(entry.mesh, entry.up_axis),
        }
    out: dict[str, Any] = {
        "scenario": scenario_to_display(scn),
        "geometry": {
            "triangles": int(geom.faces.shape[0]),
            "objects": per_object,
            "watertight": dict(zip(geom.objects, map(bool, geom.object_watertight))),
            "bounds_m": [list(map(float, geom.bounds[0])), list(map(float, geom.bounds[1]))],
        },
        "media": {},
    }
    if scn.output.regions:
        out["regions"] = check_regions(scn)
    out["materials_band"] = materials_band(res)
    for f in scn.frequencies:
        media = build_media(res.db, geom.material_ids, f, scn.render.default_temperature, scn.atmosphere)
        kinds = {v: k for k, v in KIND_CODES.items()}
        out["media"][f"{f / 1e9:g} GHz"] = {
            mid: {
                "kind": kinds[int(media.kind[i])],
                **(
                    {"eps": [float(media.eps[i].real), float(media.eps[i].imag)]}
                    if int(media.kind[i]) not in (METAL, BLACKBODY)
                    else {}
                ),
                "temperature_K": float(media.temperature[i]),
                **({"loss_dB_per_km": float(media.alpha[i] * 1e3 * 10 / np.log(10))} if media.alpha[i] > 0 else {}),
                **({"coating_layers": int(media.coating[i].eps.size)} if media.coating[i] is not None else {}),
                **(
                    {"rough_coating_layers": [repr(layer.roughness) for layer in media.rough_layers(i)]}
                    if media.rough_layers(i)
                    else {}
                ),
                **({"roughness": repr(media.rough(i))} if media.rough(i) is not None else {}),
                **({"bump": repr(media.bump_map(i))} if media.bump_map(i) is not None else {}),
            }
            for i, mid in enumerate(media.ids)
        }
    im = scn.imager
    cam = Camera.look_at(im.position, im.look_at, im.up, im.fov, im.resolution)  # the render's (make_job)
    imager = {
        f"{f / 1e9:g} GHz": imager_summary(scn, SimpleNamespace(k0=2.0 * np.pi * f / C0, camera=cam))
        for f in scn.frequencies
    }
    if any(imager.values()):  # NETD and the beam, as the render's report states them
        out["imager"] = imager
    if scn.sky.model == "texture":  # read and check it now, as render would
        make_sky(scn.sky, scn.frequencies[0])
    if scn.sky.model == "slab":  # the values the render takes, defaults included
        out["sky"] = {}
        for f in scn.frequencies:
            sky = make_sky(scn.sky, f)
            out["sky"][f"{f / 1e9:g} GHz"] = {
                "model": "slab",
                "temperature_K": sky.temperature,
                "zenith_opacity_Np": round(sky.tau, 5),
                "zenith_opacity_from": "sky.zenith_opacity"
                if scn.sky.zenith_opacity is not None
                else "default: clear US standard atmosphere (18.5 K at 35 GHz, 46 K at 95 GHz at the zenith)",
                "zenith_K": round(float(sky.zenith_angle_temperature(np.pi / 2)), 2),
                "elevation_10deg_K": round(float(sky.zenith_angle_temperature(np.radians(10.0))), 2),
            }
    est = estimate_resources(scn, int(geom.faces.shape[0]), scn.render.workers or default_workers())
    free = available_memory()
    out["resources"] = {
        "camera_paths_at_most": est["camera_paths_at_most"],
        "memory_GB": round(est["memory_bytes"] / 1e9, 3),
        **({"memory_available_GB": round(free / 1e9, 3)} if free is not None else {}),
        "disk_GB": round(est["disk_bytes"] / 1e9, 3),
        "time_s_rough": round(est["time_s_rough"], 1),
    }
    if free is not None and est["memory_bytes"] > free:
        warn(
            f"the render needs about {est['memory_bytes'] / 1e9:.3g} GB of memory and {free / 1e9:.3g} GB are "
            "available: `pmmw render` will refuse it without --force"
        )
    out["warnings"] = collected_warnings()
    return out
