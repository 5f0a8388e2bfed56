"""The shell sessions shown in docs/user-guide.md run and print what the page says.

The Python examples of ``docs/*.md`` are doctests (``--doctest-glob``); this
test covers the ``console`` blocks of the user guide, which show ``netdae``
commands with their output. Its purpose is to keep the page true to the
program, so the expected text *is* the page: each block is run and its output
compared with what the page shows.

Block syntax (the usual shell-transcript conventions):

- ``$ command`` is a command, ``> more`` continues it (here-documents);
- the lines after a command are its expected output (stdout and stderr
  together), up to the next command;
- a line ``...`` stands for any number of lines (trimmed output), and
  ``...`` inside a line for any text within that line (times, paths).

Commands run with ``bash`` in a fresh directory that holds a link
``netlists`` to the repository's netlists; ``netdae`` is the command line of
the netdae being tested (``netdae.cli.main``). Blocks that call
``netdae compare`` or ``netdae demo`` need ngspice and are skipped without it.

``python tests/test_docs.py`` prints every block's actual output, to refresh
the page after a deliberate change.
"""

from __future__ import annotations

import os
import re
import shlex
import shutil
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
GUIDE = ROOT / "docs" / "user-guide.md"
#: Commands that need ngspice.
NGSPICE_COMMANDS = ("netdae compare", "netdae demo")
#: Seconds a block may take (the demo runs a transient and ngspice).
BLOCK_TIMEOUT = 300
#: Trimming marker, alone on a line or inside one.
ELLIPSIS = "..."


@dataclass
class Step:
    command: str
    expected: list[str]


@dataclass
class Block:
    line: int
    steps: list[Step]

    @property
    def needs_ngspice(self) -> bool:
        return any(name in step.command for step in self.steps for name in NGSPICE_COMMANDS)


def console_blocks(text: str) -> list[Block]:
    """The ``console`` blocks of a Markdown page, split into commands and expected output."""
    blocks: list[Block] = []
    lines = text.splitlines()
    i = 0
    while i < len(lines):
        if lines[i].strip() != "```console":
            i += 1
            continue
        start = i + 1
        i += 1
        steps: list[Step] = []
        while i < len(lines) and lines[i].strip() != "```":
            line = lines[i]
            if line.startswith("$ "):
                steps.append(Step(line[2:], []))
            elif line.startswith("> ") or line == ">":
                if not steps or steps[-1].expected:
                    raise ValueError(f"{GUIDE.name}:{i + 1}: a continuation line must follow a command")
                steps[-1].command += "\n" + line[2:]
            elif steps:
                steps[-1].expected.append(line)
            else:
                raise ValueError(f"{GUIDE.name}:{i + 1}: a console block must start with '$ command'")
            i += 1
        blocks.append(Block(start + 1, steps))
        i += 1
    return blocks


def pattern(expected: list[str]) -> re.Pattern:
    """A regular expression for the expected lines, with ``...`` as the wildcard."""
    parts = []
    for line in expected:
        if line.strip() == ELLIPSIS:
            parts.append(r"(?:[^\n]*\n)*?")
        else:
            pieces = [re.escape(p) for p in line.rstrip().split(ELLIPSIS)]
            parts.append(r"[^\n]*?".join(pieces) + r"[ \t]*\n")
    return re.compile("".join(parts))


def normalise(output: str) -> str:
    out = output.replace("\r\n", "\n")
    return out if out.endswith("\n") or not out else out + "\n"


def run_step(command: str, cwd: Path) -> str:
    """Run one command with ``netdae`` bound to the netdae under test; stdout and stderr together."""
    python = shlex.quote(sys.executable)
    prelude = (f'netdae() {{ {python} -c "import sys; from netdae.cli import main; '
               f'sys.exit(main(sys.argv[1:]))" "$@"; }}\n')
    env = dict(os.environ)
    env["PATH"] = os.path.dirname(sys.executable) + os.pathsep + env.get("PATH", "")
    env.pop("NETDAE_DEBUG", None)
    env.setdefault("MPLBACKEND", "Agg")
    done = subprocess.run(["bash", "-c", prelude + command], cwd=cwd, env=env, stdout=subprocess.PIPE,
                          stderr=subprocess.STDOUT, text=True, timeout=BLOCK_TIMEOUT)
    return normalise(done.stdout)


def run_block(block: Block, workdir: Path) -> list[tuple[Step, str]]:
    (workdir / "netlists").symlink_to(ROOT / "netlists", target_is_directory=True)
    return [(step, run_step(step.command, workdir)) for step in block.steps]


BLOCKS = console_blocks(GUIDE.read_text(encoding="utf-8")) if GUIDE.exists() else []


def test_the_guide_has_console_blocks():
    assert len(BLOCKS) >= 10, "docs/user-guide.md lost its command examples"


@pytest.mark.parametrize("block", BLOCKS, ids=[f"line{b.line}" for b in BLOCKS])
def test_console_block(block, tmp_path):
    if block.needs_ngspice and shutil.which("ngspice") is None:
        pytest.skip("ngspice is not installed (install it with: sudo apt-get install ngspice libngspice0 "
                    "libngspice0-dev)")
    for step, output in run_block(block, tmp_path):
        if pattern(step.expected).fullmatch(output) is None:
            shown = "\n".join(step.expected)
            pytest.fail(f"docs/user-guide.md:{block.line}: `{step.command}` printed\n{output}\n"
                        f"which does not match the page:\n{shown}", pytrace=False)


def test_pattern_wildcards():
    p = pattern(["a ... c", "...", "end"])
    assert p.fullmatch("a b c\nx\ny\nend\n")
    assert p.fullmatch("a  c\nend\n")
    assert not p.fullmatch("a b d\nend\n")
    assert not p.fullmatch("a b c\nend\nmore\n")


def main() -> int:
    """Print the actual output of every block of the guide (to refresh the page)."""
    for block in BLOCKS:
        print(f"---- docs/user-guide.md:{block.line}")
        with tempfile.TemporaryDirectory() as tmp:
            for step, output in run_block(block, Path(tmp)):
                print("$ " + step.command.replace("\n", "\n> "))
                print(output, end="")
    return 0


if __name__ == "__main__":
    sys.exit(main())
