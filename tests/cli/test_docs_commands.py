"""Every input file a command in the README or docs/*.md names is shipped (the README's commands
once named `glass_on_copper.yaml`, `plate.stl`, `part.glb` and `slurm.yaml`, none of which existed).

A command is a line of a shell code block starting with ``pmmw`` or ``python``; an input is an
argument with a file extension that no output option (``--out``, ``--plot``) precedes. Files under
``out/`` (written by an earlier command) and absolute paths (a user's own folders) are not checked.
"""

from __future__ import annotations

import shlex
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md")), ROOT / "scenes" / "README.md"]
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
    return [t for i, t in enumerate(tokens) if t.endswith(INPUTS) and "=" not in t
            and not (i and tokens[i - 1] in OUTPUT_OPTIONS) and not t.startswith(("out/", "/"))]


def test_every_input_a_documented_command_names_is_shipped():
    missing = [(doc.name, t) for doc in DOCS for cmd in _commands(doc.read_text()) for t in _inputs(cmd)
               if not (ROOT / t).exists()]
    assert missing == []


def test_the_check_sees_a_missing_file_and_skips_outputs():
    """Control: a command naming a file that is not shipped is caught; outputs are not inputs."""
    cmds = _commands("```sh\npmmw po plate.stl --plot plate.png --out out/po\npmmw view out/x.exr\n```\n")
    assert [_inputs(c) for c in cmds] == [["plate.stl"], []]
    # the commands the fix was about are among those found
    found = {tuple(c[:3]) for doc in DOCS for c in _commands(doc.read_text())}
    assert {("pmmw", "brdf", "--stack"), ("pmmw", "po", "scenes/po/beacon_plate.ply")} <= found
