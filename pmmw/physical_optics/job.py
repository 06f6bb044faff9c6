"""`pmmw po JOB.yaml`: physical-optics jobs from a file (`configs/po_*.yaml`).

A job names its targets as a scenario names its scene (meshes, ``transform``, material ids from
the database, ``materials`` overrides), and lists frequencies, polarizations and an observation
grid::

    name: beacon_plate
    targets:
      - {mesh: ../scenes/po/beacon_plate.ply, material: metal}
    frequency: [35 GHz, 95 GHz]
    polarization: [theta, phi]         # default [theta]
    monostatic: true                   # or incidence: [30 deg, 0 deg]
    observation: {theta: "0:90:0.05", phi: "270"}
    bounces: 1
    output: {dir: out/po_beacon_plate}

It writes, per frequency and polarization, ``<name>_<f>GHz_<pol>.csv`` / ``.json`` / ``.png``,
an EXR map (``rcs_theta``, ``rcs_phi`` over theta rows and phi columns) when the grid covers the
whole sphere, and ``report.md`` with every run's backscatter and peak.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Literal, Optional, Union

import numpy as np
from pydantic import Field, field_validator, model_validator

from pmmw import interrupt
from pmmw.config.schema import Quantity, SceneEntry, _Model, frequency_problem
from pmmw.errors import UserError
from pmmw.io.lock import output_lock
from pmmw.io.records import validate
from pmmw.io.yamlio import read_yaml
from pmmw.physical_optics import command, solver


class Observation(_Model):
    theta: Union[str, float] = "0:180:1"  # [deg] START:STOP:STEP or one angle
    phi: Union[str, float, list[float]] = 0.0  # [deg] START:STOP:STEP, one angle or a list


class PoOutputConfig(_Model):
    dir: Optional[Path] = None
    plot: bool = True


class PoJob(_Model):
    name: str
    source_file: Path
    targets: tuple[SceneEntry, ...]
    materials: dict[str, dict] = {}
    frequencies: Annotated[tuple[float, ...], Quantity("frequency", many=True)]
    polarization: tuple[Literal["theta", "phi"], ...] = ("theta",)
    incidence: Annotated[Optional[tuple[float, float]], Quantity("angle", n=2)] = None  # [rad]
    monostatic: bool = False
    observation: Observation = Observation()
    bounces: int = Field(1, ge=1, le=command.MAX_BOUNCES)
    method: Literal["auto", "direct", "octree"] = "auto"
    tube: Annotated[Optional[float], Quantity("length")] = None
    output: PoOutputConfig = PoOutputConfig()

    @field_validator("polarization", mode="before")
    @classmethod
    def _pols(cls, v):
        return (v,) if isinstance(v, str) else v

    @field_validator("frequencies")
    @classmethod
    def _freqs(cls, out):
        if not out:
            raise ValueError("give at least one frequency")
        why = next(filter(None, map(frequency_problem, out)), None)
        if why:
            raise ValueError(why)
        return out

    @model_validator(mode="after")
    def _mode(self):
        if self.monostatic == (self.incidence is not None):
            raise ValueError("give either `monostatic: true` or an `incidence: [theta, phi]`, not both or neither")
        return self


def load_job(path: Path, out: Path | None = None) -> PoJob:
    """Read and check a job file; every problem is named by file and key."""
    raw = read_yaml(path, "physical-optics job")
    if not isinstance(raw, dict):
        raise UserError("a job is a mapping (name, targets, frequency, ...)", path)
    data = dict(raw)
    data.setdefault("name", path.stem)
    data["source_file"] = str(path.resolve())
    if "frequency" in data:
        data["frequencies"] = data.pop("frequency")
    if isinstance(data.get("targets"), list):
        data["targets"] = [
            dict(e, key=f"targets[{i}]") if isinstance(e, dict) else e for i, e in enumerate(data["targets"])
        ]
    if out is not None:
        data["output"] = dict(data.get("output") or {}, dir=str(out))
    job = validate(
        PoJob,
        data,
        path,
        context={"base_dir": path.resolve().parent},
        relocate=lambda loc: ["frequency" if p == "frequencies" else p for p in loc],
        allowed=lambda loc, names: ["frequency" if n == "frequencies" else n for n in names],
    )
    if job.output.dir is not None and not job.output.dir.is_absolute():
        object.__setattr__(job.output, "dir", Path.cwd() / job.output.dir)
    return job


def _targets(job: PoJob, f: float):
    from pmmw.pipeline import check_material_ids
    from pmmw.scene.geometry import build_geometry
    from pmmw.scene.materials import MaterialDB

    db = MaterialDB.load().with_overrides(dict(job.materials), file=job.source_file)
    check_material_ids(job.targets, db, job.source_file)
    geom = build_geometry(job.targets, scenario_file=job.source_file)
    return solver.make_target(geom.vertices, geom.faces, geom.face_material, geom.material_ids, db, f)


def _angles(value, option, theta: bool) -> np.ndarray:
    if isinstance(value, list):
        return np.radians(np.array(value, float))
    text = str(value)
    return command.parse_theta(text, option=option) if theta else command.parse_phi(text, option=option)


def run_job(path: Path, out: Path | None = None, force: bool = False) -> list[Path]:
    """Run every (frequency, polarization) of the job; returns the files written. ``force``:
    solve past the memory check (`command.compute`)."""
    job = load_job(Path(path), out)
    key = str(job.source_file)
    thetas = _angles(job.observation.theta, f"{key}: observation.theta", True)
    phis = _angles(job.observation.phi, f"{key}: observation.phi", False)
    tt, pp = command.grid(thetas, phis)
    out_dir = job.output.dir or Path.cwd() / "out" / job.name
    with (
        output_lock(out_dir, "--out" if out is not None else f"{key}: output.dir"),
        interrupt.outcome(interrupt.COMMAND_OUTCOMES["po"]),  # what it says is back as it was after
    ):
        return _run_locked(job, out_dir, thetas, phis, tt, pp, force)


def _run_locked(job, out_dir: Path, thetas, phis, tt, pp, force: bool = False) -> list[Path]:
    """`run_job` in its locked output folder."""
    th_i, ph_i = job.incidence if job.incidence is not None else (0.0, 0.0)
    written, runs = [], []
    for f in job.frequencies:
        target = _targets(job, f)
        for pol in job.polarization:
            res = command.compute(
                target,
                f,
                th_i,
                ph_i,
                pol,
                tt,
                pp,
                monostatic=job.monostatic,
                bounces=job.bounces,
                method=job.method,
                tube=job.tube,
                force=force,
                source=job.source_file,
            )
            stem = f"{job.name}_{f / 1e9:g}GHz_{pol}"
            interrupt.outcome(
                f"files already written in {out_dir} are complete, the others missing; run the "
                "job again to write them all"
            )
            written += command.write_run(res, out_dir, stem, job.name, thetas, phis, job.output.plot)
            runs.append((stem, res))
    observation = f"theta `{job.observation.theta}`, phi `{job.observation.phi}` (degrees)"
    written.append(command.write_report(out_dir, job.name, str(job.source_file), runs, observation, job.output.plot))
    return written
