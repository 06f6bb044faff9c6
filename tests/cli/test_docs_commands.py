"""Every input file a command in the README or the site's pages (docs/**/*.md) names is shipped (the README's commands
once named `glass_on_copper.yaml`, `plate.stl`, `part.glb` and `slurm.yaml`, none of which existed).

A command is a line of a shell code block starting with ``pmmw`` or ``python``; an input is an
argument with a file extension that no output option (``--out``, ``--plot``) precedes. Files under
``out/`` (written by an earlier command) and absolute paths (a user's own folders) are not checked.

Also: every ``pmmw`` command they show names a command and options the command line has (so a
renamed option fails here), every Python block parses and uses only names the API has, every YAML
block parses; and the cheap commands run (``pmmw validate``, ``pmmw materials``, ``pmmw sky`` on
shipped files).
"""

from __future__ import annotations

import shlex
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
# the README, every page of the site (docs/**/*.md) and the scene scripts' guide
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md")), ROOT / "scenes" / "README.md"]
INPUTS = (".yaml", ".yml", ".ply", ".glb", ".gltf", ".obj", ".stl", ".exr", ".py")
OUTPUT_OPTIONS = {"--out", "--plot"}


def _commands(text: str) -> list[list[str]]:
    """The commands of the shell code blocks (fences ```sh, ```bash, ```console or bare ```)."""
    out, lang, lines = [], None, []
    for raw in text.splitlines():
        fence = raw.strip().startswith("```")
        if fence and lang is None:
            lang, lines = raw.strip()[3:].strip(), []
            continue
        if fence:
            if lang in ("", "sh", "bash", "console"):
                block = "\n".join(lines).replace("\\\n", " ")  # continued lines joined
                for line in block.splitlines():
                    line = line.split("  #")[0].strip()
                    if line.startswith(("pmmw ", "python ")):
                        try:
                            out.append(shlex.split(line))
                        except ValueError:  # shell syntax shlex does not take: the words as they stand
                            out.append(line.split())
            lang = None
            continue
        if lang is not None:
            lines.append(raw)
    return out


def _inputs(tokens: list[str]) -> list[str]:
    return [
        t
        for i, t in enumerate(tokens)
        if t.endswith(INPUTS)
        and "=" not in t
        and not (i and tokens[i - 1] in OUTPUT_OPTIONS)
        and not t.startswith(("out/", "/"))
    ]


def test_every_input_a_documented_command_names_is_shipped():
    missing = [
        (doc.name, t)
        for doc in DOCS
        for cmd in _commands(doc.read_text())
        for t in _inputs(cmd)
        if not (ROOT / t).exists()
    ]
    assert missing == []


def test_the_check_sees_a_missing_file_and_skips_outputs():
    """Control: a command naming a file that is not shipped is caught; outputs are not inputs."""
    cmds = _commands("```sh\npmmw po plate.stl --plot plate.png --out out/po\npmmw view out/x.exr\n```\n")
    assert [_inputs(c) for c in cmds] == [["plate.stl"], []]
    # the commands the fix was about are among those found
    found = {tuple(c[:3]) for doc in DOCS for c in _commands(doc.read_text())}
    assert {("pmmw", "brdf", "--stack"), ("pmmw", "po", "scenes/po/beacon_plate.ply")} <= found


# -- the site's pages: every command's subcommand and options exist, every code block parses -------

SITE = DOCS


def _blocks(text: str, langs: tuple[str, ...]) -> list[str]:
    """The code blocks of the given fence languages, as text."""
    out, lang, lines = [], None, []
    for raw in text.splitlines():
        fence = raw.strip().startswith("```")
        if fence and lang is None:
            lang, lines = raw.strip()[3:].strip().split(" ")[0], []
        elif fence:
            if lang in langs:
                out.append("\n".join(lines))
            lang = None
        elif lang is not None:
            lines.append(raw)
    return out


def _cli():
    import typer.main

    from pmmw_cli.cli import app

    return typer.main.get_command(app)


def _unknown_options(cmd_tokens: list[str], root) -> list[str]:
    """The words of one ``pmmw ...`` command that name no command or option of the typer app."""
    cmd, words = root, cmd_tokens[1:]
    while words and hasattr(cmd, "commands") and not words[0].startswith("-"):
        if words[0] not in cmd.commands:
            return [f"command {words[0]!r}"]
        cmd, words = cmd.commands[words[0]], words[1:]
    known = {o for p in cmd.params if p.param_type_name == "option" for o in [*p.opts, *p.secondary_opts]}
    known.add("--help")
    bad = []
    for w in words:
        if w.startswith("#") or w in ("|", ">", "&&", ";"):
            break
        name = w.split("=", 1)[0]
        if name.startswith("-") and not name[1:2].isdigit() and name not in known:
            bad.append(f"option {name!r} of {' '.join(cmd_tokens[:2])}")
    return bad


def test_every_documented_command_and_option_exists():
    root = _cli()
    bad = [
        (doc.relative_to(ROOT).as_posix(), " ".join(cmd), why)
        for doc in SITE
        for cmd in _commands(doc.read_text())
        if cmd[0] == "pmmw"
        for why in _unknown_options(cmd, root)
    ]
    assert bad == []


def test_the_option_check_sees_a_renamed_option_and_a_missing_command():
    """Control: an option or a command the app lacks is caught; real ones and values are not."""
    root = _cli()
    assert _unknown_options(["pmmw", "render", "configs/x.yaml", "--sppp", "4"], root) == [
        "option '--sppp' of pmmw render"
    ]
    assert _unknown_options(["pmmw", "rendr", "configs/x.yaml"], root) == ["command 'rendr'"]
    assert _unknown_options(["pmmw", "materials", "show", "water", "--frequency", "95 GHz"], root) == []
    assert _unknown_options(["pmmw", "render", "x.yaml", "--set", "imager.resolution=[64,64]", "--spp=2"], root) == []


def test_every_python_block_compiles_and_names_real_api():
    """Python blocks parse, and every ``pmmw.NAME`` they use is in the API (``pmmw.render``, ...)."""
    import ast
    import re

    import pmmw

    bad = []
    for doc in SITE:
        for block in _blocks(doc.read_text(), ("python", "py")):
            where = doc.relative_to(ROOT).as_posix()
            try:
                ast.parse(block)
            except SyntaxError as e:
                bad.append((where, f"syntax: {e.msg}: {block.splitlines()[e.lineno - 1] if e.lineno else ''}"))
                continue
            bad += [
                (where, f"pmmw.{n}")
                for n in re.findall(r"\bpmmw\.([A-Za-z_]\w*)", block)
                if not hasattr(pmmw, n) and not (ROOT / "pmmw" / n).exists()
            ]
    assert bad == []


def test_every_yaml_block_parses():
    import yaml

    bad = []
    for doc in SITE:
        for block in _blocks(doc.read_text(), ("yaml", "yml")):
            try:
                yaml.safe_load(block)
            except yaml.YAMLError as e:
                bad.append((doc.relative_to(ROOT).as_posix(), str(e).splitlines()[0]))
    assert bad == []


CHEAP = ("validate", "materials", "sky", "version")  # commands that render nothing: seconds each
OUTPUT_VALUE_OPTIONS = {"--out", "--plot", "--exr"}


def _cheap_commands() -> list[tuple[str, list[str]]]:
    seen, out = set(), []
    for doc in DOCS:
        for cmd in _commands(doc.read_text()):
            if cmd[0] == "pmmw" and len(cmd) > 1 and cmd[1] in CHEAP and tuple(cmd) not in seen:
                seen.add(tuple(cmd))
                out.append((doc.relative_to(ROOT).as_posix(), cmd))
    return out


def test_the_cheap_documented_commands_run(tmp_path):
    """Every ``pmmw validate / materials / sky / version`` command shown runs as shown (from the
    repository root, on shipped files), its outputs written into a temporary folder instead."""
    import os
    import subprocess
    import sys

    cmds = _cheap_commands()
    assert {c[1] for _, c in cmds} >= {"validate", "materials"}  # the pages show some: the check is not empty
    # a .blend needs the optional blender extra (bpy): run where it is (make test-blender sets
    # PMMW_BLENDER_PYTHON), else only check that the file it names is shipped
    with_bpy = bool(os.environ.get("PMMW_BLENDER_PYTHON"))
    blends = [c for _, c in cmds if any(a.endswith(".blend") for a in c)]
    assert all((ROOT / a).is_file() for c in blends for a in c if a.endswith(".blend"))
    if not with_bpy:
        cmds = [(w, c) for w, c in cmds if c not in blends]
    failed = []
    for i, (where, cmd) in enumerate(cmds):
        args = [
            str(tmp_path / f"{i}_{Path(a).name}") if j and cmd[j - 1] in OUTPUT_VALUE_OPTIONS else a
            for j, a in enumerate(cmd)
        ]
        run = subprocess.run(
            [sys.executable, "-m", "pmmw_cli", *args[1:]],
            cwd=ROOT,
            capture_output=True,
            text=True,
            timeout=300,
            env=dict(os.environ, MPLBACKEND="Agg"),
        )
        if run.returncode != 0:
            failed.append((where, " ".join(cmd), run.stderr.strip().splitlines()[-1:]))
    assert failed == []


def _broken_links(text: str, base: Path) -> list[str]:
    """Relative Markdown links (``[text](path)``, images too) whose file is not in the repository."""
    import re

    targets = re.findall(r"\]\((?!https?:|mailto:|#)([^)\s]+)\)", text)
    return [t for t in targets if not (base / t.split("#")[0]).exists()]


def test_the_readme_links_resolve():
    """The README is read on GitHub and is not part of the site, whose strict build checks the
    pages' links: its own links into docs/ are checked here."""
    assert _broken_links((ROOT / "README.md").read_text(), ROOT) == []
    # control: a link to a page that does not exist is caught, one that exists is not
    assert _broken_links("[a](docs/guide/nope.md) [b](docs/guide/scenario.md#x) [c](https://x.org)", ROOT) == [
        "docs/guide/nope.md"
    ]
