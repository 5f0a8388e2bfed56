"""The control language's safe subset (netdae.netlist.control): variables, loops, conditionals, alter.

Each construct runs in ngspice 39 itself (``ngspice -b`` runs the netlist's own control
block, which writes its plots with ``write``) and in netdae (which runs its interpreter
over the same block); the k-th result of each is compared, in units of the tolerance.
"""

from __future__ import annotations

import subprocess

import numpy as np
import pytest

import netdae
from netdae.errors import NetlistError
from netdae.io.raw import read_raw
from netdae.netlist import load
from netdae.netlist.control import MAX_COMMAND_LENGTH, MAX_ITERATIONS, MAX_NESTING

#: netdae's tolerances for the comparisons: reltol and the voltage floor.
RELTOL, VNTOL = 1e-6, 1e-9


def ngspice_results(tmp_path, text: str, exe: str):
    """ngspice's plots of a netlist whose control block writes them (``write out.raw``, ``set appendwrite``)."""
    (tmp_path / "netlist.cir").write_text(text)
    done = subprocess.run([exe, "-b", "-n", "netlist.cir"], cwd=tmp_path, capture_output=True, text=True,
                          timeout=120)
    # ngspice -b runs the (absent) dot analyses after the block: "no simulations run", status 1
    assert done.returncode == 0 or "no simulations run" in done.stderr, done.stderr
    return read_raw(tmp_path / "out.raw")


def assert_close(nd, ng, signals, scale_floor=1e-3, tol=1e-3):
    """netdae's and ngspice's values of ``signals`` agree within ``tol`` of each signal's scale."""
    assert nd.analysis == ng.analysis
    for name in signals:
        ours, theirs = np.asarray(nd[name]), np.asarray(ng[name])
        if nd.analysis == "tran":  # on ngspice's time points, from netdae's dense output
            ours = np.asarray(nd.dense(ng.t)[name])
        scale = max(np.max(np.abs(theirs)), scale_floor)
        err = np.max(np.abs(ours - theirs)) / scale
        assert err < tol, f"{nd.analysis} {name}: {err:.3g} of the scale"


@pytest.mark.ngspice
def test_let_set_csparam_substitution_against_ngspice(tmp_path, ngspice_exe):
    """``.csparam``, ``let``, ``set``, ``$&x``, ``$x``, ``{$x}`` in analysis arguments and alter values:
    netdae substitutes what ngspice does (a vector as %G: 1/30k -> 3.33333E-05)."""
    text = """substitution
V1 a 0 dc 0 sin(0 1 1k)
R1 a b 1k
C1 b 0 100n
.param tend = 2m
.csparam tstop = {tend}
.control
set appendwrite
let step = tstop/300
set amp = 2
tran $&step $&tstop 0 $&step
write out.raw
let f = 1/(tstop*0.25)
alter @v1[sin] [ 0 {$amp} $&f ]
set rr = 3k
alter r1 = $rr
tran $&step $&tstop 0 $&step
write out.raw
.endc
.end
"""
    ng = ngspice_results(tmp_path, text, ngspice_exe)
    circuit = load(text)
    first, second = circuit.analyses
    assert (first.tstep, first.tstop, first.tmax) == (float("6.66667E-06"), 2e-3, float("6.66667E-06"))
    assert not first.alter and [c.command for c in second.alter] == ["alter @v1[sin] [ 0.0 2.0 2000.0 ]",
                                                                     "alter r1 = 3000.0"]
    nd = netdae.run(circuit, reltol=RELTOL, vntol=VNTOL)
    assert [r.analysis for r in nd] == [r.analysis for r in ng] == ["tran", "tran"]
    for ours, theirs in zip(nd, ng):
        assert_close(ours, theirs, ["v(a)", "v(b)"], tol=2e-3)
    assert np.max(np.abs(ng[1]["v(a)"])) == pytest.approx(2.0, rel=1e-3)  # the altered amplitude ran in both


@pytest.mark.ngspice
def test_foreach_alter_element_ac_against_ngspice(tmp_path, ngspice_exe):
    """``foreach`` with ``alter name = $var``, ``alter name value``, ``alter @r1[resistance] =`` and a source's
    ``ac``: one .ac per value, the k-th of netdae against ngspice's k-th (ac1, ac2, ...)."""
    text = """foreach
V1 a 0 dc 0 ac 1
R1 a b 1k
C1 b 0 1u
L1 b c 1m
R2 c 0 50
.control
set appendwrite
foreach rv 100 1k 10k
  alter r1 = $rv
  ac dec 5 10 1meg
  write out.raw
end
alter r1 500
ac dec 5 10 1meg
write out.raw
alter @r1[resistance] = 2k
ac dec 5 10 1meg
write out.raw
alter v1 ac = 2
ac dec 5 10 1meg
write out.raw
.endc
.end
"""
    ng = ngspice_results(tmp_path, text, ngspice_exe)
    nd = netdae.run(load(text))
    assert len(nd) == len(ng) == 6
    assert abs(nd[5]["v(b)"][0]) == pytest.approx(2 * abs(nd[4]["v(b)"][0]), rel=1e-12)
    for ours, theirs in zip(nd, ng):
        assert_close(ours, theirs, ["v(b)", "v(c)"], tol=1e-9)
    assert abs(nd[0]["v(b)"][-1]) != pytest.approx(abs(nd[2]["v(b)"][-1]))  # the values changed the circuit


@pytest.mark.ngspice
def test_while_if_repeat_dowhile_break_continue_against_ngspice(tmp_path, ngspice_exe):
    """Loops and conditionals on scalar vectors: the same operating points in the same order."""
    text = """loops
V1 a 0 1
R1 a b 1k
R2 b 0 1k
.control
set appendwrite
let i = 0
while i < 10
  let i = i + 1
  if i = 2
    continue
  end
  if i gt 4
    break
  else
    alter v1 = $&i
  end
  op
  write out.raw
end
repeat 2
  alter r2 = 3k
  op
  write out.raw
end
let j = 0
dowhile j < 0
  let j = j + 1
  alter r1 2k
  op
  write out.raw
end
.endc
.end
"""
    ng = ngspice_results(tmp_path, text, ngspice_exe)
    nd = netdae.run(load(text))
    assert len(nd) == len(ng) == 6  # i = 1, 3, 4; repeat 2; dowhile once
    for ours, theirs in zip(nd, ng):
        assert_close(ours, theirs, ["v(a)", "v(b)"], tol=1e-9)
    assert [float(r["v(a)"][0]) for r in nd] == [1.0, 3.0, 4.0, 4.0, 4.0, 4.0]


@pytest.mark.ngspice
def test_altermod_against_ngspice(tmp_path, ngspice_exe):
    """``altermod model param = value`` and ``altermod @model[param]``: the model changes for the analyses after."""
    text = """altermod
V1 a 0 1
R1 a b 1k
D1 b 0 dmod
.model dmod d is=1e-14 n=1
.control
set appendwrite
op
write out.raw
altermod dmod is = 1e-12
op
write out.raw
altermod @dmod[n] = 2
op
write out.raw
.endc
.end
"""
    ng = ngspice_results(tmp_path, text, ngspice_exe)
    nd = netdae.run(load(text))
    assert len(nd) == len(ng) == 3
    for ours, theirs in zip(nd, ng):
        assert_close(ours, theirs, ["v(b)"], tol=1e-6)
    assert float(nd[2]["v(b)"][0]) > float(nd[0]["v(b)"][0]) + 0.1


@pytest.mark.ngspice
@pytest.mark.parametrize("backend", ["shared", "subprocess"])
def test_compare_pairs_the_kth_analysis_with_ngspices_kth(tmp_path, backend):
    """``netdae compare`` runs a script's analyses in ngspice with netdae's alter commands before each."""
    from netdae.comparison import compare

    path = tmp_path / "c.cir"
    path.write_text("""compare script
V1 a 0 dc 0 ac 1 pulse(0 1 0 1u 1u 1m 2m)
R1 a b 1k
C1 b 0 1u
.control
foreach rv 1k 4k
  alter r1 = $rv
  ac dec 5 10 100k
  tran 5u 2m
end
alter @v1[pulse] [ 0 2 0 1u 1u 0.5m 1m ]
tran 5u 2m
.endc
.end
""")
    result = compare(str(path), tight=True, backend=backend)
    kinds = [(a.analysis, a.occurrence) for a in result.analyses]
    assert kinds == [("ac", 0), ("tran", 0), ("ac", 1), ("tran", 1), ("tran", 2)]
    assert all(a.passed for a in result.analyses), result


@pytest.mark.ngspice
@pytest.mark.parametrize("backend", ["shared", "subprocess"])
def test_commands_naming_elements_in_upper_case_reach_ngspice(tmp_path, backend):
    """ngspice lowercases a deck's control lines as it reads them, not the commands given to its library: the
    shared backend sent 'dc VIN 0 10 5' as written and ngspice found no source VIN (ngspice's own example
    new-check-3.sp, which agreed before the script ran on netdae's interpreter)."""
    from netdae.comparison import compare

    path = tmp_path / "c.cir"
    path.write_text("upper case\nVIN 1 0 DC=0\nR1 1 2 1k\nR2 2 0 3k\n.control\nlet n = 2\n"
                    "dc VIN 0 10 $&n\nalter R2 = 1k\ndc VIN 0 10 5\n.endc\n.end\n")
    result = compare(str(path), backend=backend)
    assert [(a.analysis, a.occurrence) for a in result.analyses] == [("dc", 0), ("dc", 1)]
    assert all(a.passed for a in result.analyses), result


@pytest.mark.ngspice
def test_meas_commands_are_read_as_meas_cards(tmp_path):
    """'meas tran vmax max v(out)' after 'run' (ngspice's common idiom) was skipped as control language; it is the
    .meas card (one analysis of its kind: ngspice's last plot is it), compared with ngspice's control-block meas."""
    from netdae.comparison import compare

    path = tmp_path / "m.cir"
    path.write_text("meas in control\nV1 in 0 SIN(0 1 1k)\nR1 in out 1k\nC1 out 0 1u\n.tran 10u 2m\n.control\nrun\n"
                    "meas tran vmax max v(out)\nmeasure tran tcross when v(out)=0.1 rise=1\n.endc\n.end\n")
    circuit = netdae.load(str(path))
    assert [c.name for c in circuit.measures] == ["vmax", "tcross"]
    result = compare(str(path), tight=True)
    values = {m.name: m for m in result.measures}
    assert set(values) == {"vmax", "tcross"}
    for m in values.values():
        assert m.relative is not None and m.relative < 1e-4, m  # the difference is the simulators' at --tight


def test_a_meas_command_in_a_loop_is_skipped_with_its_remedy():
    text = ("t\nV1 in 0 PULSE(0 1 0 1n 1n 1 2)\nR1 in out 1k\nC1 out 0 100n\n.control\nforeach rv 1k 2k\n"
            "  alter R1 = $rv\n  tran 1u 3m\n  meas tran t50 when v(out)=0.5 cross=1\nend\n.endc\n.end\n")
    said = {str(d.location): d.message for d in netdae.load(text).diagnostics}
    assert "reads meas commands outside loops and conditionals only" in said["<string>:9:3"]
    assert "it reads op, tran" not in said["<string>:9:3"]  # the general note said meas was read


def test_meas_commands_netdae_cannot_measure_are_skipped_not_refused():
    """A control block's meas of a vector 'let' made, of an unknown function, or of an analysis the netlist does
    not run is skipped with a located note or warning (ngspice reports such a command failed and goes on); the
    netlist runs and measures the rest."""
    text = ("t\nV1 in 0 SIN(0 1 1k)\nR1 in out 1k\nC1 out 0 1u\n.tran 10u 2m\n.control\nrun\n"
            "let gain = v(out)/v(in)\nmeas tran g1 max gain\nmeas tran bogus frobnicate v(out)\n"
            "meas ac q find vdb(out) at=1k\nmeas tran vmax max v(out)\n.endc\n.end\n")
    circuit = netdae.load(text)
    assert [m.name for m in circuit.measures] == ["vmax"]
    said = {str(d.location): d.message for d in circuit.diagnostics}
    assert "expected a signal after MAX, found 'gain'" in said["<string>:9:1"]
    assert "unknown measurement function 'frobnicate'" in said["<string>:10:1"]
    assert "skipped (a .control block's meas command): no .ac card" in said["<string>:11:1"]
    (res,) = netdae.run(circuit)
    (vmax,) = res.measures
    assert vmax.name == "vmax" and vmax.value == pytest.approx(np.max(res["v(out)"]), rel=1e-2)


def test_unbounded_loops_are_refused_at_the_loop():
    with pytest.raises(NetlistError, match=f"more than {MAX_ITERATIONS:,} loop iterations") as info:
        load("t\nV1 a 0 1\nR1 a 0 1k\n.control\nlet i = 0\nwhile i < 1\n  op\nend\n.endc\n.end\n")
    assert info.value.location.line == 6
    with pytest.raises(NetlistError, match=f"more than {MAX_ITERATIONS:,} loop iterations") as info:
        load("t\nV1 a 0 1\nR1 a 0 1k\n.control\nrepeat\nop\nend\n.endc\n.end\n")
    assert info.value.location.line == 5
    # repeat without a count runs until 'break' (ngspice's control_structs/repeat3.sp)
    circuit = load("t\nV1 a 0 1\nR1 a 0 1k\n.control\nlet i = 0\nrepeat\nlet i = i + 1\nif i > 3\nbreak\nend\n"
                   "op\nend\n.endc\n.end\n")
    assert len(circuit.analyses) == 3


def test_unknown_variable_is_located():
    with pytest.raises(NetlistError, match="no variable 'x'") as info:
        load("t\nV1 a 0 1\nR1 a 0 1k\n.control\ntran 1u $x\n.endc\n.end\n")
    assert (info.value.location.line, info.value.location.column) == (5, 1)
    with pytest.raises(NetlistError, match="no vector 'tstop'") as info:
        load("t\nV1 a 0 1\nR1 a 0 1k\n.param tstop=1m\n.control\ntran 1u $&tstop\n.endc\n.end\n")
    assert info.value.location.line == 6


def test_a_variable_outside_control_is_a_comment_and_the_card_is_refused():
    """Outside a control block ``$`` starts a comment (as in ngspice): a card whose value was ``$x`` lacks it."""
    with pytest.raises(NetlistError) as info:
        load("t\nV1 a 0 1\nR1 a 0 $x\n.op\n.end\n")
    assert info.value.location is not None and info.value.location.line == 3


@pytest.mark.parametrize("command", ["alter r1 foo = 5", "alter @r1[foo] = 5"])
def test_alter_of_a_parameter_the_element_does_not_have_is_located(command):
    # ngspice: "Error: no such parameter foo."; netdae said the circuit was altered and changed nothing
    with pytest.raises(NetlistError, match=r"no such parameter 'foo' of r1 \(a resistor\)") as info:
        load(f"t\nV1 in 0 1\nR1 in a 1k\nR2 a 0 1k\n.control\n{command}\nop\n.endc\n.end\n")
    assert (info.value.location.line, info.value.location.column) == (6, 1)


def test_alter_of_a_missing_element_is_located():
    with pytest.raises(NetlistError, match="no element 'r9'") as info:
        load("t\nV1 a 0 1\nR1 a 0 1k\n.control\nop\nalter r9 = 2k\nop\n.endc\n.end\n")
    assert info.value.location.line == 6
    with pytest.raises(NetlistError, match="no model 'nomod'"):
        load("t\nV1 a 0 1\nR1 a 0 1k\n.control\naltermod nomod is = 1\nop\n.endc\n.end\n")


def test_vector_of_results_refuses_the_analyses_that_depend_on_it():
    text = ("t\nV1 a 0 1\nR1 a 0 1k\n.control\nop\nlet unused = v(a)\nlet x = v(a)\nalter v1 = $&x\nop\n"
            "echo done\n.endc\n.end\n")
    circuit = load(text)
    assert len(circuit.analyses) == 1  # the op before the alter runs
    notes = {d.location.line: d.message for d in circuit.diagnostics if d.location is not None}
    assert "netdae's script keeps numbers only" in notes[6]
    assert "the analyses after it are skipped" in notes[8]
    assert "it follows 'alter v1 = $&x' (<string>:8:1)" in notes[9] and "vector 'x'" in notes[9]


def test_monte_carlo_script_is_refused_naming_the_random_draw():
    """The corpus's Monte Carlo: a 'define'd function drawing sunif in an alter stops the analyses."""
    text = """mc
V1 a 0 ac 1
R1 a b 1k
C1 b 0 1n
.control
let run = 0
define unif(nom, rvar) (nom + (nom*rvar) * sunif(0))
dowhile run < 3
  alter c1 = unif(1e-09, 0.1)
  ac oct 10 1k 1meg
  let run = run + 1
end
.endc
.end
"""
    circuit = load(text)
    assert circuit.analyses == []
    with pytest.raises(netdae.NetdaeError, match="'ac oct 10 1k 1meg' at <string>:10:3 was skipped because it "
                                                 "follows 'alter c1 = unif") as info:
        netdae.run(circuit)
    assert "sunif" in str(info.value)


def test_plain_blocks_still_read_as_cards():
    """A block without the control language reads as before: its commands as cards, the rest noted."""
    circuit = load("t\nV1 a 0 1\nR1 a 0 1k\n.control\nset reltol=1e-6\nop\nprint v(a)\nshell ls\n.endc\n")
    assert len(circuit.analyses) == 1 and circuit.options.reltol == 1e-6 and not circuit.analyses[0].alter


@pytest.mark.ngspice
def test_alter_instance_parameter_against_ngspice(tmp_path, ngspice_exe):
    """``alter d1 area = 3`` and ``alter @d1[area] = 0.5``: an instance parameter of a top-level element."""
    text = """instance
V1 a 0 1
R1 a b 1k
D1 b 0 dmod
.model dmod d is=1e-14 n=1
.control
set appendwrite
op
write out.raw
alter d1 area = 3
op
write out.raw
alter @d1[area] = 0.5
op
write out.raw
.endc
.end
"""
    ng = ngspice_results(tmp_path, text, ngspice_exe)
    nd = netdae.run(load(text))
    assert len(nd) == len(ng) == 3
    for ours, theirs in zip(nd, ng):
        assert_close(ours, theirs, ["v(b)"], tol=1e-9)
    assert float(nd[1]["v(b)"][0]) < float(nd[0]["v(b)"][0]) < float(nd[2]["v(b)"][0])


def test_alter_of_an_instance_parameter_inside_a_subcircuit_is_refused():
    text = ("t\nV1 a 0 1\nX1 a 0 sub\n.subckt sub p n\nD1 p n dmod\n.model dmod d\n.ends\n.control\n"
            "alter d.x1.d1 area = 2\nop\n.endc\n.end\n")
    with pytest.raises(NetlistError, match="not the parameter 'area' of d.x1.d1") as info:
        load(text)
    assert info.value.location.line == 9


SCRIPTED = """scripted
V1 a 0 dc 0 pulse(0 1 0 1u 1u 1m 2m)
R1 a b 1k
C1 b 0 1u
.control
foreach rv 1k 2k
  alter r1 = $rv
  tran 10u 1m
end
.endc
.end
"""


def test_cli_writes_one_file_per_run_and_check_names_the_changes(tmp_path, capsys):
    from netdae.cli import main as cli_main

    path = tmp_path / "s.cir"
    path.write_text(SCRIPTED)
    assert cli_main(["check", str(path)]) == 0
    out = capsys.readouterr().out
    assert "(after alter r1 = 1000.0)" in out and "(after alter r1 = 2000.0)" in out
    assert cli_main(["run", "-q", str(path), "--out", str(tmp_path / "out")]) == 0
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["tran.csv", "tran2.csv"]


def test_sweep_refuses_a_script_that_alters():
    text = SCRIPTED.replace("R1 a b 1k", ".param c=1u\nR1 a b 1k").replace("C1 b 0 1u", "C1 b 0 {c}")
    with pytest.raises(netdae.NetdaeError, match=r"the netlist's .control script alters the circuit \('alter r1 = "
                                                 r"1000.0'\)"):
        netdae.sweep(load(text), params={"c": [1e-6, 2e-6]})


@pytest.mark.parametrize("value, message", [
    ("0", "zero resistance for 'r1'"),
    ("1e300", "the value 1e+300 of 'r1' is outside the magnitudes netdae's matrices hold"),
])
def test_an_alter_to_a_value_the_element_cannot_take_is_located_at_the_command(value, message):
    """'alter R1 = 0' was reported at R1's card as 'values: zero resistance for 'r1'' (the word of the internal
    argument that carries it), not at the command that set it."""
    text = f"t\nV1 a 0 1\nR1 a b 1k\nC1 b 0 1n\n.control\nalter R1 = {value}\nop\n.endc\n.end\n"
    with pytest.raises(NetlistError) as info:
        netdae.run(load(text))
    assert (info.value.location.line, info.value.location.column) == (6, 1)
    assert info.value.message.startswith(f".control: 'alter r1 = {float(value)!r}': {message}")


def test_growing_variables_and_deep_nesting_are_refused_at_their_line():
    text = ("t\nV1 a 0 1\nR1 a 0 1k\n.control\nset x = ab\nrepeat 100\n  set x = \"$x $x\"\nend\nop\n"
            ".endc\n.end\n")
    with pytest.raises(NetlistError, match=f"more than netdae's limit of {MAX_COMMAND_LENGTH:,}") as info:
        load(text)
    assert info.value.location.line == 7
    deep = "".join(f"if 1\n" for _ in range(MAX_NESTING + 1)) + "op\n" + "end\n" * (MAX_NESTING + 1)
    with pytest.raises(NetlistError, match=f"nested deeper than {MAX_NESTING}") as info:
        load(f"t\nV1 a 0 1\nR1 a 0 1k\n.control\n{deep}.endc\n.end\n")
    assert info.value.location.line == 5 + MAX_NESTING


@pytest.mark.ngspice
def test_threshold_memristor_three_frequencies_against_ngspice():
    """ngspice's memristor example (Pershin and Di Ventra's threshold model): .csparam values, let,
    tran $&..., and alter @v1[sin] between three transients; compare pairs tran1..tran3.

    The threshold function as the example writes it, ``beta*y + 0.5*(alpha-beta)*(abs(y+vt)-abs(y-vt))``:
    with beta = 2e12 it is rounding noise of +-2e-4 A inside the threshold (1e-9 gives -1.65e-4, 1e-8
    gives +1.2e-4), compared as a tie with 0 (netdae.devices.autodiff.ROUNDING_TIE); read as signed, the
    source's current was that noise, which netdae's error test rejected down to h = 5e-46 s (ngspice's
    looks only at the 1 F capacitor's charge).
    """
    from netdae.comparison import compare

    text = """memristor with threshold
.param stime=10n
.param vmax = 3
.csparam stime={stime}
.csparam vmax={vmax}
Xmem 1 0 memristor
V1 0 1 DC 0 sin(0 'vmax' '1/stime')
.subckt memristor plus minus PARAMS: Ron=1K Roff=10K Rinit=7.0K alpha=0 beta=20e3/stime Vt=1.6
Bx 0 x I='((f1(V(plus)-V(minus))> 0) && (V(x) < Roff)) ? {f1(V(plus)-V(minus))}: ((((f1(V(plus)-V(minus)) < 0) && (V(x)>Ron)) ? {f1(V(plus)-V(minus))}: 0)) '
Vx x x1 dc 0
Cx x1 0 1 IC={Rinit}
Rmem plus minus r={V(x)}
.func f1(y)={beta*y+0.5*(alpha-beta)*(abs(y+Vt)-abs(y-Vt))}
.ends
.control
let deltime = stime/100
tran $&deltime $&stime uic
let newfreq = 1.1/stime
let newstime = stime/1.1
let deltime = newstime/100
alter @V1[sin] [ 0 $&vmax $&newfreq ]
tran $&deltime $&newstime uic
let newfreq = 1.4/stime
let newstime = stime/1.4
let deltime = newstime/100
alter @V1[sin] [ 0 $&vmax $&newfreq ]
tran $&deltime $&newstime uic
.endc
.end
"""
    circuit = load(text)
    assert [a.tstop for a in circuit.analyses] == [1e-8, float("9.09091E-09"), float("7.14286E-09")]
    result = compare(text)
    assert [(a.analysis, a.occurrence) for a in result.analyses] == [("tran", 0), ("tran", 1), ("tran", 2)]
    assert all(a.passed for a in result.analyses), result


def test_a_measurement_of_a_transient_only_the_script_runs():
    """``.meas tran`` with the script's ``tran`` as the only transient: measured on the first (as ngspice's tran1)."""
    text = ("t\nV1 a 0 pulse(0 1 0 1u 1u 1m 2m)\nR1 a b 1k\nC1 b 0 1u\n.meas tran vmax max v(b)\n.control\n"
            "foreach rv 1k 2k\n  alter r1 = $rv\n  tran 10u 1m\nend\n.endc\n.end\n")
    results = netdae.run(load(text), reltol=1e-6)
    assert [m.name for m in results[0].measures] == ["vmax"] and not results[1].measures
    assert results[0].measures[0].value == pytest.approx(1 - np.exp(-1), rel=1e-3)  # 1 - exp(-t/RC) at t = RC


def test_with_params_runs_the_script_again():
    text = ("t\n.param tend=1m\n.csparam ts={tend}\nV1 a 0 1\nR1 a b 1k\nC1 b 0 1u\n.control\nlet h = ts/100\n"
            "tran $&h $&ts\nalter r1 = 2k\ntran $&h $&ts\n.endc\n.end\n")
    c = load(text)
    d = c.with_params(tend=2e-3)
    assert [a.tstop for a in c.analyses] == [1e-3, 1e-3] and [a.tstop for a in d.analyses] == [2e-3, 2e-3]
    assert [a.tstep for a in d.analyses] == [2e-5, 2e-5] and [x.command for x in d.analyses[1].alter] == \
        ["alter r1 = 2000.0"]
