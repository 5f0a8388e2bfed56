"""Output files are written whole or not at all, and a failed write says why.

Each write runs in a child process with a limit the operating system enforces:
``RLIMIT_FSIZE`` (what ``ulimit -f`` sets) makes the write fail with EFBIG
part-way through the file, and a directory without write permission refuses
the file (for root, the child runs without the capability that overrides
file permissions, through ``setpriv``). The oracle is the file system: no
file and no temporary file may be left, an earlier file of the same name must
be unchanged, and the error must be an ``OutputFileError`` naming the file and
the reason.
"""

from __future__ import annotations

import json
import os
import resource
import shutil
import stat
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from netdae.errors import NetdaeError, OutputFileError
from netdae.io.files import atomic_output, write_bytes
from netdae.io.raw import read_raw

from conftest import NETLISTS, ROOT

#: A file-size limit (bytes) below what every write below produces.
SIZE_LIMIT = 120

#: The child: writes with one writer and prints what happened as JSON.
CHILD = textwrap.dedent(
    """
    import json, sys
    import numpy as np
    from netdae.results import Result
    from netdae.netlist import load
    kind, path = sys.argv[1], sys.argv[2]
    t = np.linspace(0.0, 1e-3, 2000)
    tran = Result("tran", axes={"time": t}, signals={"v(out)": np.sin(t * 1e4), "i(v1)": np.cos(t * 1e4) * 1e-3})
    try:
        if kind == "raw":
            from netdae.io.raw import write_raw
            write_raw(path, [tran])
        elif kind == "ascii-raw":
            from netdae.io.raw import write_raw
            write_raw(path, [tran], binary=False)
        elif kind == "csv":
            from netdae.io.csv import write_csv
            write_csv(path, tran)
        elif kind in ("npz", "mtx"):
            from netdae.io.matrices import export_matrices
            export_matrices(load(sys.argv[3]), path)
        elif kind == "png":
            from netdae.plotting import plot_result
            plot_result(tran, path)
        elif kind == "cli":
            from netdae.cli import main
            sys.exit(main(["run", sys.argv[3], "--out", path, "--format", "raw"]))
    except Exception as exc:
        print(json.dumps({"type": type(exc).__name__, "message": str(exc),
                          "netdae": type(exc).__module__.startswith("netdae"),
                          "oserror": isinstance(exc, OSError)}))
    else:
        print(json.dumps({"type": None}))
    """
)


def _child(args, *, size_limit=None, drop_override=False):
    # no bytecode written under the file-size limit: a truncated .pyc would break every later import
    env = dict(os.environ, PYTHONPATH=str(ROOT), MPLBACKEND="Agg", PYTHONDONTWRITEBYTECODE="1")
    command = [sys.executable, "-c", CHILD, *map(str, args)]
    if drop_override:
        command = [shutil.which("setpriv"), "--bounding-set", "-dac_override,-dac_read_search", *command]

    def limit():
        if size_limit is not None:
            resource.setrlimit(resource.RLIMIT_FSIZE, (size_limit, size_limit))

    return subprocess.run(command, env=env, capture_output=True, text=True, timeout=120, preexec_fn=limit)


def _outcome(done) -> dict:
    assert done.stdout.strip(), done.stderr
    return json.loads(done.stdout.strip().splitlines()[-1])


RC = NETLISTS / "rc_lowpass.cir"


@pytest.mark.parametrize("kind, name", [("raw", "out.raw"), ("ascii-raw", "out.raw"), ("csv", "out.csv"),
                                        ("npz", "m.npz"), ("mtx", "m.mtx"), ("png", "out.png")])
def test_a_write_over_the_file_size_limit_leaves_nothing_and_says_why(tmp_path, kind, name):
    target = tmp_path / name
    outcome = _outcome(_child([kind, target, RC], size_limit=SIZE_LIMIT))
    assert outcome["type"] == "OutputFileError", outcome
    assert outcome["netdae"] and outcome["oserror"]
    assert str(target.name) in outcome["message"] or "m." in outcome["message"]
    assert "file-size limit" in outcome["message"]
    assert os.listdir(tmp_path) == []  # neither the file nor a temporary one


def test_an_earlier_file_survives_a_failed_write(tmp_path):
    target = tmp_path / "out.raw"
    target.write_bytes(b"the earlier file")
    outcome = _outcome(_child(["raw", target], size_limit=SIZE_LIMIT))
    assert outcome["type"] == "OutputFileError"
    assert target.read_bytes() == b"the earlier file"
    assert os.listdir(tmp_path) == ["out.raw"]


def test_the_command_line_reports_a_failed_write_as_an_error_not_a_bug(tmp_path):
    out = tmp_path / "res"
    out.mkdir()
    done = _child(["cli", out, RC], size_limit=SIZE_LIMIT)
    assert done.returncode == 2, done.stderr
    assert f"cannot write {out / 'tran.raw'}: the file-size limit was reached" in done.stderr
    assert "bug" not in done.stderr
    assert os.listdir(out) == []


def _read_only_directory(tmp_path) -> tuple[Path, bool]:
    folder = tmp_path / "ro"
    folder.mkdir()
    folder.chmod(0o555)
    drop = os.geteuid() == 0
    if drop and shutil.which("setpriv") is None:
        pytest.skip("running as root without setpriv: a read-only directory cannot be enforced")
    return folder, drop


@pytest.mark.parametrize("kind, name", [("raw", "out.raw"), ("csv", "out.csv"), ("png", "out.png")])
def test_a_read_only_directory_is_reported_as_such(tmp_path, kind, name):
    folder, drop = _read_only_directory(tmp_path)
    try:
        outcome = _outcome(_child([kind, folder / name], drop_override=drop))
    finally:
        folder.chmod(0o755)
    assert outcome["type"] == "OutputFileError", outcome
    assert outcome["message"] == f"cannot write {folder / name}: permission denied"
    assert os.listdir(folder) == []


def test_a_read_only_out_directory_is_refused_before_the_run(tmp_path):
    """netdae run --out DIR on an existing directory the user cannot write: said before the transient runs,
    not by cutting it at its first point (and a sweep's rows are not lost to the measures file)."""
    folder, drop = _read_only_directory(tmp_path)
    try:
        done = _child(["cli", folder, RC], drop_override=drop)
    finally:
        folder.chmod(0o755)
    assert done.returncode == 2, done.stderr
    assert done.stderr.strip() == (f"netdae: error: cannot write {folder}: the --out directory does not take files: "
                                   "Permission denied (hint: give a directory you can write into)")
    assert done.stdout == "" and os.listdir(folder) == []


@pytest.mark.skipif(not (os.path.exists("/dev/full") and stat.S_ISCHR(os.stat("/dev/full").st_mode)),
                    reason="no /dev/full device")
def test_a_device_is_written_into_never_replaced():
    """/dev/full as the output file: 'the disk is full', and /dev/full stays the device (a rename over it, as a
    regular file's atomic write does, replaced it with the plot for every process on the machine)."""
    with pytest.raises(OutputFileError, match=r"^cannot write /dev/full: the disk is full$"):
        write_bytes("/dev/full", b"x" * 10_000)
    assert stat.S_ISCHR(os.stat("/dev/full").st_mode)
    write_bytes("/dev/null", b"abc")
    assert stat.S_ISCHR(os.stat("/dev/null").st_mode)


def test_a_directory_as_the_output_file_is_refused(tmp_path):
    with pytest.raises(OutputFileError, match=r"it is a directory"):
        write_bytes(tmp_path, b"abc")
    assert tmp_path.is_dir()


def test_a_file_written_whole_reads_back_and_has_the_usual_permissions(tmp_path):
    target = tmp_path / "x.bin"
    write_bytes(target, b"abc")
    assert target.read_bytes() == b"abc" and os.listdir(tmp_path) == ["x.bin"]
    umask = os.umask(0)
    os.umask(umask)
    assert target.stat().st_mode & 0o777 == 0o666 & ~umask


def test_an_exception_inside_the_block_removes_the_temporary_file(tmp_path):
    with pytest.raises(ZeroDivisionError):
        with atomic_output(tmp_path / "x.bin") as handle:
            handle.write(b"half")
            1 / 0
    assert os.listdir(tmp_path) == []


def test_output_file_error_is_a_netdae_error_and_an_os_error(tmp_path):
    with pytest.raises(OutputFileError) as info:
        write_bytes(tmp_path / "no" / "such" / "dir.bin", b"")
    assert isinstance(info.value, NetdaeError) and isinstance(info.value, OSError)
    assert info.value.path == str(tmp_path / "no" / "such" / "dir.bin")
    assert str(info.value).endswith("the directory does not exist")


def test_what_a_failed_write_would_have_left_is_refused_by_read_raw(tmp_path):
    # the file a plain open()/write() leaves when the limit cuts it: its first SIZE_LIMIT bytes
    from netdae.io.raw import format_raw
    from netdae.results import Result

    t = np.linspace(0.0, 1.0, 2000)
    data = format_raw([Result("tran", axes={"time": t}, signals={"v(out)": t})], date="now")
    (tmp_path / "short.raw").write_bytes(data[:2000])
    with pytest.raises(NetdaeError, match="announces 2000 points, the file holds"):
        read_raw(tmp_path / "short.raw")


@pytest.mark.skipif(not (os.path.exists("/dev/full") and stat.S_ISCHR(os.stat("/dev/full").st_mode)),
                    reason="no /dev/full device")
def test_a_full_standard_output_is_said_in_words():
    """``netdae run --json > /dev/full``: the output has no file name, and the message said ``[Errno 28] No space
    left on device``; now it says what could not be written and why, as for a file."""
    with open("/dev/full", "w") as full:
        done = subprocess.run([sys.executable, "-m", "netdae", "run", str(NETLISTS / "rc_lowpass.cir"), "--json"],
                              stdout=full, stderr=subprocess.PIPE, text=True, cwd=ROOT,
                              env={**os.environ, "NETDAE_SERVER": "0"}, timeout=300)
    assert done.returncode == 2
    assert done.stderr.strip().splitlines()[-1] == "netdae: error: cannot write the output: the disk is full"
