"""netdae never makes ngspice run commands, whatever the netlist or the directory holds.

Every netlist here WOULD create a marker file if ngspice ran its control
language: a ``.control`` block in the main file, in an included file, in a
``.lib`` section, after ``.end``, in odd case or as ``.controlfoo``; a
``*ng_script`` title (the whole file becomes a script); a ``.title
*ng_script`` card; ``*#`` command comments; a ``.include`` on the title line;
a ``.spiceinit`` in the current directory. Each runs through both backends
(the shared library and the batch subprocess) and the marker must not exist
afterwards. The markers are absolute paths, so the test does not depend on
the directory ngspice runs in.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from netdae.errors import NetlistError, NgspiceError
from netdae.ngspice import run_ngspice, run_ngspice_file
from netdae.ngspice.shared import library_path

pytestmark = pytest.mark.ngspice

needs_library = pytest.mark.skipif(library_path() is None, reason="ngspice's shared library is not installed")
BACKENDS = [pytest.param("shared", marks=needs_library), "subprocess"]
ROOT = Path(__file__).resolve().parent.parent

CIRCUIT = "V1 in 0 1\nR1 in out 1k\nR2 out 0 1k\n.op\n"


def _control(marker: Path, header: str = ".control") -> str:
    return f"{header}\nshell touch {marker}\necho pwned > {marker}\n.endc\n"


def _cases(tmp: Path, marker: Path) -> dict[str, tuple[str, tuple[type, str] | None]]:
    """name -> (main netlist text, None when it runs, or the error and its message)."""
    (tmp / "evil.inc").write_text(f"* a vendor model file\n{_control(marker)}.model dx d is=1e-14\n")
    (tmp / "evil.lib").write_text(f"* library\n.lib typ\n{_control(marker)}.model dy d is=1e-14\n.endl\n")
    return {
        "main file": (f"t\n{CIRCUIT}{_control(marker)}.end\n", None),
        "included file": (f"t\n.include evil.inc\n{CIRCUIT}.end\n", None),
        "lib section": (f"t\n.lib evil.lib typ\n{CIRCUIT}.end\n", None),
        "after .end": (f"t\n{CIRCUIT}.end\n{_control(marker)}", None),
        "odd case": (f"t\n{CIRCUIT}{_control(marker, '.CoNtRoL')}.end\n", None),
        # netdae's reader meets the .endc first
        ".controlfoo": (f"t\n{CIRCUIT}{_control(marker, '.controlfoo')}.end\n", (NetlistError, "control")),
        ".controls": (f"t\n{CIRCUIT}{_control(marker, '.controls')}.end\n", (NetlistError, "control")),
        "controlfoo alone": (f"t\n{CIRCUIT}.controlfoo\n.end\n", (NetlistError, "controlfoo")),
        "ng_script title": (f"*ng_script\nshell touch {marker}\n{CIRCUIT}.end\n", (NetlistError, "shell")),
        # as a circuit, 'Echo ...' is a malformed VCVS: ngspice refuses it rather than running it
        "ng_script title card": (f"t\n.title *ng_script\nEcho pwned > {marker}\n{CIRCUIT}.end\n",
                                 (NgspiceError, "ngspice failed")),
        "star-hash command": (f"t\n{CIRCUIT}*#shell touch {marker}\n.end\n", None),
        "include on the title line": (f".include evil.inc\n{CIRCUIT}.end\n", None),
        "include variant": (f"t\n.includex evil.inc\n{CIRCUIT}.end\n", (NetlistError, "includex")),
        "at sign": (f"t\n{CIRCUIT}@\n{_control(marker)}.end\n", (NetlistError, "@")),
    }


CASE_NAMES = [
    "main file", "included file", "lib section", "after .end", "odd case", ".controlfoo", ".controls",
    "controlfoo alone",
    "ng_script title", "ng_script title card", "star-hash command", "include on the title line",
    "include variant", "at sign",
]


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("case", CASE_NAMES)
def test_no_netlist_card_makes_ngspice_run_a_command(tmp_path, backend, case):
    marker = tmp_path / "pwned"
    text, refused = _cases(tmp_path, marker)[case]
    path = tmp_path / "main.cir"
    path.write_text(text)
    if refused is None:
        run = run_ngspice_file(path, backend=backend)
        assert run.result("op")["v(out)"][0] == pytest.approx(0.5, rel=1e-12)
        assert ".control" not in run.netlist.lower() and "*#" not in run.netlist
    else:
        error, match = refused
        with pytest.raises(error, match=match):
            run_ngspice_file(path, backend=backend)
    assert not marker.exists(), f"ngspice ran a command of the netlist ({case})"


def test_skipped_blocks_and_dropped_cards_are_noted(tmp_path):
    marker = tmp_path / "pwned"
    text, _ = _cases(tmp_path, marker)["after .end"]
    run = run_ngspice(text.replace(".end\n", f".control\nrun\nshell touch {marker}\n.endc\n.end\n", 1),
                      backend="subprocess")
    assert any(".control: 'shell touch" in n and "skipped" in n for n in run.notes)
    assert any("after .end" in n and "not passed to ngspice" in n for n in run.notes)


def test_the_netlist_ngspice_gets_is_self_contained(tmp_path):
    marker = tmp_path / "pwned"
    text, _ = _cases(tmp_path, marker)["included file"]
    run = run_ngspice(text, backend="subprocess", workdir=tmp_path)
    lines = [line.lower() for line in run.netlist.splitlines()]
    assert ".model dx d is=1e-14" in lines
    assert not any(line.startswith((".inc", ".lib", "*", ".control", ".endc")) for line in lines[1:])
    assert lines[-1] == ".end" and lines.count(".end") == 1


SPICEINIT_SCRIPT = """
import sys
from netdae.ngspice import run_ngspice
run = run_ngspice("t\\nV1 in 0 1\\nR1 in 0 1k\\n.op\\n.end\\n", backend=sys.argv[1])
print(run.backend, run.result("op")["v(in)"][0])
"""


@pytest.mark.parametrize("backend", BACKENDS)
def test_a_spiceinit_in_the_current_directory_is_not_read(tmp_path, backend):
    marker = tmp_path / "pwned"
    (tmp_path / ".spiceinit").write_text(f"* user init\nshell touch {marker}\necho pwned > {marker}\n")
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    done = subprocess.run([sys.executable, "-c", SPICEINIT_SCRIPT, backend], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == [backend, "1.0"]
    assert not marker.exists(), "ngspice read the .spiceinit of the current directory"
