"""Bad input after the reader: every command answers with a located error, never an internal one.

The classes here were found by ``scripts/fuzz_commands.py`` (mutated netlists
that read but mean something wrong); each runs the command line in process on
a tiny netlist and checks the exit status, the location and what was expected.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

import netdae
from netdae.cli import EXIT_ERROR, EXIT_FAIL, main
from netdae.errors import NetlistError
from netdae.io.csv import read_csv

PULSE_BEFORE_ZERO = """negative pulse delay
v1 in 0 pulse(0 1 -1 1n 1n 1u 0)
r1 in 0 1k
{analysis}
.end
"""


def _cli(capsys, tmp_path, text, *argv):
    path = tmp_path / "bad.cir"
    path.write_text(text)
    status = main([argv[0], str(path), *argv[1:]])
    _, err = capsys.readouterr()
    return status, err, path


@pytest.mark.parametrize("command", ["run", "index"])
@pytest.mark.parametrize("analysis", [".op", ".dc v1 0 1 0.5"])
def test_waveform_started_before_zero_needs_a_dc_value(capsys, tmp_path, command, analysis):
    """A negative delay moves a PULSE's start before t = 0: its .op value waits for .tran defaults."""
    status, err, path = _cli(capsys, tmp_path, PULSE_BEFORE_ZERO.format(analysis=analysis), command, "-q")
    assert status == EXIT_ERROR, err
    assert "bug in netdae" not in err
    assert f"{path}:2:1: v1: the PULSE starts before t = 0 (a negative delay)" in err
    assert "expected: a DC value ('dc v0') or every PULSE parameter written" in err
    assert "hint: add 'dc 0'" in err


def test_waveform_started_before_zero_with_a_dc_value_runs(capsys, tmp_path):
    """The DC value is what .op uses, so a written one settles it (ngspice's rule)."""
    text = PULSE_BEFORE_ZERO.replace("v1 in 0 pulse", "v1 in 0 dc 0.25 pulse").format(analysis=".op")
    status, err, _ = _cli(capsys, tmp_path, text, "run", "-q")
    assert status == 0, err
    result = netdae.run(netdae.load(text))[0]
    assert result.signals["v(in)"][0] == pytest.approx(0.25)


def test_waveform_determined_at_zero_unless_started_before():
    from netdae.netlist.waveforms import Pulse

    assert Pulse(0, 1, 0).determined_at(0.0)
    assert not Pulse(0, 1, -1).determined_at(0.0)
    assert Pulse(0, 1, -1).resolved(1e-9, 1e-6).determined_at(0.0)


def test_waveform_started_before_zero_through_the_api(tmp_path):
    circuit = netdae.load(PULSE_BEFORE_ZERO.format(analysis=".op"), path=str(tmp_path / "p.cir"))
    with pytest.raises(NetlistError) as info:
        netdae.run(circuit)
    assert info.value.location.line == 2 and "v1" in info.value.message


RLC = """rlc
v1 in 0 dc 1
r1 in a {r}
l1 a out {l}
c1 out 0 {c}
g1 0 out a 0 {g}
.op
.end
"""
VALUES = {"r": "20", "l": "10m", "c": "1u", "g": "1m"}


@pytest.mark.parametrize("command", ["run", "index", "check"])
@pytest.mark.parametrize("element,value,shown", [
    ("c", "1e308", "1e+308"), ("c", "1e-300", "1e-300"), ("r", "{1/1e-300}", "1e+300"), ("r", "1e-200", "1e-200"),
    ("l", "-1e160", "-1e+160"), ("g", "1e300", "1e+300"),
])
def test_element_value_beyond_the_matrices_range(capsys, tmp_path, command, element, value, shown):
    """A stamped value the dense analyses would overflow on (squared, or inverted for a resistor) is refused at its card."""
    values = dict(VALUES, **{element: value})
    status, err, path = _cli(capsys, tmp_path, RLC.format(**values), command, "-q")
    assert status == EXIT_ERROR, err
    assert "bug in netdae" not in err and "Warning" not in err
    line = 1 + ["r", "l", "c", "g"].index(element) + 2
    column = RLC.splitlines()[line - 1].index("{") + 1
    assert f"{path}:{line}:{column}: {element}1: value {shown} is outside the magnitudes netdae's matrices hold " \
           "(1e-150 to 1e+150" in err
    assert f"expected: {element.upper()}name n+ n-" in err


def test_element_values_at_the_range_ends_run(capsys, tmp_path):
    values = dict(VALUES, c="1e-150", l="1e150")
    status, err, _ = _cli(capsys, tmp_path, RLC.format(**values), "run", "-q")
    assert status == 0, err


DIODE_MODEL = """diode with a model parameter out of range
v1 in 0 dc 0.6
r1 in a 1k
d1 a 0 dm
.model dm d is=1e-14 cjo=1e300
{analysis}
.end
"""


@pytest.mark.parametrize("command,analysis,what", [
    ("index", ".op", "the index analysis"), ("run", ".pz a 0 a 0 vol pz", ".pz"),
])
def test_linearised_entries_beyond_the_dense_range(capsys, tmp_path, command, analysis, what):
    """A model parameter out of range makes a linearisation the dense analyses cannot hold: refused by name."""
    status, err, _ = _cli(capsys, tmp_path, DIODE_MODEL.format(analysis=analysis), command, "-q")
    assert status == EXIT_ERROR, err
    assert "bug in netdae" not in err and "Warning" not in err
    found = re.search(rf"{re.escape(what)}: the circuit linearised at its operating point has entries of magnitude "
                      r"(\S+) \(above 1e\+150", err)
    assert found and float(found.group(1)) >= 1e300, err  # cjo itself, and more at forward bias
    assert "in the equations of v(a)" in err and "hint: a device model parameter out of range" in err


@pytest.mark.parametrize("card,token,what,shown", [
    ("v1 in 0 dc -1e300", "-1e300", "DC value", "-1e+300"), ("v1 in 0 dc 1 ac 1e300", "1e300", "AC magnitude", "1e+300"),
    ("v1 in 0 pulse(0 1e300 0 1n 1n 1u 2u)", "1e300", "PULSE parameter", "1e+300"),
    ("i1 0 in sin(0 1 {1e160})", "{1e160}", "SIN parameter", "1e+160"),
])
@pytest.mark.parametrize("command", ["run", "index"])
def test_source_value_beyond_the_solvers_range(capsys, tmp_path, command, card, token, what, shown):
    """A source value of 1e300 overflows every residual it enters: refused at the number."""
    text = f"huge source\n{card}\nr1 in 0 1k\n.op\n.end\n"
    status, err, path = _cli(capsys, tmp_path, text, command, "-q")
    assert status == EXIT_ERROR, err
    assert "bug in netdae" not in err and "Warning" not in err
    column = card.index(token) + 1
    name = card.split()[0]
    assert f"{path}:2:{column}: {name}: {what} {shown} is beyond the magnitudes netdae's solvers hold (up to 1e+150)" \
           in err
    assert "expected: PULSE(v1 v2 td tr tf pw per np) | SIN(" in err


GRID = """grid too large
v1 in 0 dc 1 ac 1
r1 in out {{rv}}
c1 out 0 1n
.param rv=1k
{card}
.end
"""


@pytest.mark.parametrize("card,message", [
    (".step param rv 1 1e9 1", ":6:16: .step: the sweep would have 1,000,000,001 points"),
    (".dc v1 0 1e9 1e-3", ".dc v1: the sweep would have 1,000,000,000,001 points"),
    (".dc v1 0 1 1e-6 temp 0 100 1e-4", ".dc v1 temp: the sweep would have 1,000,002,000,001 points"),
    (".ac lin 1e12 1 1k", ".ac lin: the sweep would have 1,000,000,000,000 points"),
    (".ac dec 1e9 1 1k", ".ac dec: the sweep would have 3,000,000,004 points"),
    (".noise v(out) v1 oct 1e9 1 1k", ".ac oct: the sweep would have 9,965,784,"),  # log2(1000) 1e9 + 1
])
def test_sweep_grid_beyond_the_limit(capsys, tmp_path, card, message):
    """A grid of billions of points is refused before it is built (it would take the machine's memory)."""
    status, err, path = _cli(capsys, tmp_path, GRID.format(card=card), "run", "-q", "--out", str(tmp_path / "o"))
    assert status == EXIT_ERROR, err
    assert message in err and "more than netdae's limit of 10,000,000 (check the increment" in err
    count = int(re.search(r"would have ([\d,]+) points", err).group(1).replace(",", ""))
    if "oct" in card:  # log2(1000) octaves of 1e9 points, within the grid's rounding slack
        assert abs(count - (math.log2(1000.0) * 1e9 + 1)) <= 1e-9 * count + 2
    if card.startswith(".step"):
        assert f"{path}:6:16" in err


def test_sweep_command_step_beyond_the_limit(capsys, tmp_path):
    path = tmp_path / "g.cir"
    path.write_text(GRID.format(card=".op"))
    assert main(["sweep", str(path), "--out", str(tmp_path / "o"), "--step", "rv=1:1e9:1"]) == EXIT_ERROR
    assert "rv=1:1e9:1: the sweep would have 1,000,000,001 points" in capsys.readouterr().err


def test_grid_at_the_limit():
    from netdae.netlist.steps import MAX_GRID_POINTS, grid

    assert grid("lin", 1.0, float(MAX_GRID_POINTS), 1.0).size == MAX_GRID_POINTS
    with pytest.raises(ValueError, match="10,000,001 points"):
        grid("lin", 0.0, float(MAX_GRID_POINTS), 1.0)


@pytest.mark.parametrize("values,message", [
    ({"r1": 0.0}, "values: zero resistance for 'r1'"),
    ({"c1": 1e-300}, "values: the value 1e-300 of 'c1' is outside the magnitudes netdae's matrices hold"),
    ({"v1": 1e300}, "values: the DC value 1e+300 of 'v1' is beyond the magnitudes netdae's solvers hold"),
])
def test_stepped_element_values_are_checked_as_written_ones(tmp_path, values, message):
    """A value given by a sweep (values=, .step, --step) meets the rules of one written on the card."""
    from netdae.netlist import parse
    from netdae.netlist.elaborate import elaborate

    path = tmp_path / "g.cir"
    path.write_text(GRID.format(card=".op").replace("{rv}", "1k"))
    with pytest.raises(NetlistError) as info:
        elaborate(parse(str(path)), values=values)
    assert info.value.message.startswith(message)
    line = {"r1": 3, "c1": 4, "v1": 2}[next(iter(values))]
    assert info.value.location.line == line


def test_sweep_row_with_a_zero_resistance_fails_by_name(capsys, tmp_path):
    path = tmp_path / "g.cir"
    path.write_text(GRID.format(card=".dc v1 0 1 0.5").replace("{rv}", "1k"))
    status = main(["sweep", str(path), "--out", str(tmp_path / "o"), "--step", "r1=0,1k", "--no-plot",
                   "--meas", "dc vo find v(out) at=1"])
    err = capsys.readouterr().err
    assert status != 3 and "bug in netdae" not in err
    assert "1 of 2 rows failed" in err and f"{path}:3:1: values: zero resistance for 'r1'" in err


@pytest.mark.parametrize("card,token", [(".nodeset v(out)=-1e300", "-1e300"), (".ic v(out)={1e200}", "{1e200}")])
def test_initial_value_beyond_the_solvers_range(capsys, tmp_path, card, token):
    text = GRID.format(card=f".tran 1n 1u\n{card}").replace("{rv}", "1k")
    status, err, path = _cli(capsys, tmp_path, text, "run", "-q", "--out", str(tmp_path / "o"))
    assert status == EXIT_ERROR, err
    assert "Warning" not in err and "bug in netdae" not in err
    what = card.split()[0]
    assert f"{path}:7:{card.index(token) + 1}: {what}: initial value " in err
    assert "is beyond the magnitudes netdae's solvers hold (up to 1e+150)" in err
    assert f"expected: {what} v(node)=value" in err


@pytest.mark.parametrize("card,token", [
    ("m1 out in 0 0 nm w=1e308 l=1u", "1e308"), ("m1 out in 0 0 nm w=10u l={1e200}", "{1e200}"),
    ("d1 out 0 dm area=-1e300", "-1e300"),
])
def test_instance_parameter_beyond_the_solvers_range(capsys, tmp_path, card, token):
    """A device's instance parameter of 1e308 overflowed the device's setup: refused at the number."""
    text = ("huge geometry\nvdd vdd 0 5\nvin in 0 2\nr1 vdd out 10k\n"
            f"{card}\n.model nm nmos level=1 vto=1 kp=20u\n.model dm d\n.op\n.end\n")
    status, err, path = _cli(capsys, tmp_path, text, "run", "-q")
    assert status == EXIT_ERROR, err
    assert "Warning" not in err and "bug in netdae" not in err
    name = card.split()[0]
    key = card[:card.index(token)].split()[-1].rstrip("=")
    assert f"{path}:5:{card.index(token) + 1}: {name}: parameter {key}=" in err
    assert "is beyond the magnitudes netdae's solvers hold (up to 1e+150)" in err
    assert f"expected: {name[0].upper()}name" in err


def test_sens_with_a_family_without_model_sensitivities(capsys, tmp_path):
    """.sens on a MESA MESFET: its model parameters are not differentiated, and a note says so (was a KeyError)."""
    text = ("mesa sens\nvds 1 0 2\nvgs 2 0 0\nz1 1 2 0 mm l=1u w=10u\n.model mm nmf level=2\n"
            ".sens i(vds)\n.end\n")
    status, err, path = _cli(capsys, tmp_path, text, "run")
    assert status == 0, err
    assert "bug in netdae" not in err
    assert f"{path}:4:1: z1: netdae computes no sensitivities to the model parameters of a mesa" in err


@pytest.mark.parametrize("option", ["gmin=1e300", "abstol=1e300", "vntol=1e200", "chgtol=1e151"])
def test_option_beyond_the_solvers_range(capsys, tmp_path, option):
    """A tolerance or gmin of 1e300 enters every residual and weight: refused at its number on the card."""
    text = f"options\nv1 in 0 1\nr1 in out 1k\nd1 out 0 dm\n.model dm d\n.options {option}\n.op\n.end\n"
    status, err, path = _cli(capsys, tmp_path, text, "run", "-q")
    assert status == EXIT_ERROR, err
    assert "bug in netdae" not in err
    name, value = option.split("=")
    column = len(".options ") + len(name) + 2  # 1-based column of the value
    assert f"{path}:6:{column}: .options: option '{name}' = {float(value):g} is beyond the magnitudes" in err, err
    assert "up to 1e+150" in err and "expected: .options" in err


def test_option_override_beyond_the_solvers_range():
    """The same limit for a value the caller gives (the API's overrides), named with what is expected."""
    from netdae.analyses.runner import option_problem

    assert "up to 1e150" in option_problem("gmin", 1e300) and option_problem("gmin", 1e-3) is None


def test_option_at_the_range_end_runs(capsys, tmp_path):
    text = "options\nv1 in 0 1\nr1 in out 1k\nd1 out 0 dm\n.model dm d\n.options gmin=1e-3\n.op\n.end\n"
    status, err, _ = _cli(capsys, tmp_path, text, "run", "-q")
    assert status == 0, err


@pytest.mark.parametrize("card,message", [
    (".dc v1 0 1 1e-300", ":6:1: .dc v1: the sweep would have 1e+300 points"),
    (".dc v1 0 1e300 1e-300", ":6:1: .dc v1: the sweep would have infinitely many points"),
    (".ac lin 1e300 1 2", ":6:1: .ac lin: the sweep would have 1e+300 points"),
    (".step param rv 0 1e300 1e-300", ":6:16: .step: the sweep would have infinitely many points"),
])
def test_sweep_grid_of_astronomical_size(capsys, tmp_path, card, message):
    """A count beyond 1e15 is shown in powers of ten (was three hundred digits), an infinite one named (was an
    OverflowError from a .step), and .dc and .ac refusals are located at their card."""
    status, err, path = _cli(capsys, tmp_path, GRID.format(card=card), "run", "-q", "--out", str(tmp_path / "o"))
    assert status == EXIT_ERROR, err
    assert f"{path}{message}" in err and "more than netdae's limit of 10,000,000" in err
    assert "bug in netdae" not in err and len(err) < 400


def test_logarithmic_sweep_whose_ratio_overflows(capsys, tmp_path):
    """.ac dec 1 1e-300 1e300: stop/start overflows, the decades do not: 600 decades, 601 points (was refused as
    'infinitely many')."""
    status, err, _ = _cli(capsys, tmp_path, GRID.format(card=".ac dec 1 1e-300 1e300"), "run", "-q", "--out",
                          str(tmp_path / "o"))
    assert status == 0, err
    f = read_csv(tmp_path / "o" / "ac.csv").axes["frequency"]
    assert f.size == 601
    np.testing.assert_allclose(np.log10(f), np.arange(-300, 301), rtol=0, atol=1e-12)


def test_transient_of_astronomical_size_is_refused_in_short_numbers(capsys, tmp_path):
    text = "huge tran\nv1 in 0 1\nr1 in out 1k\nc1 out 0 1u\n.tran 1e-300 1\n.end\n"
    status, err, path = _cli(capsys, tmp_path, text, "run", "-q", "--out", str(tmp_path / "o"))
    assert status == EXIT_ERROR, err
    assert f"{path}:5:1: .tran: " in err and "at 1e+300 points or more" in err and "the run cannot finish" in err
    assert len(err) < 600


def test_operating_point_of_a_current_source_into_capacitors(capsys, tmp_path):
    """A current source into a node of capacitors only: the charge-balance rows hold every Jacobian entry of the
    circuit, and np.bincount of nothing returned integers (was a UFuncTypeError, 'a bug in netdae')."""
    status, err, path = _cli(capsys, tmp_path, "t\nI1 a 0 1\nC1 a 0 1\n.op\n.end\n", "run", "-q")
    assert status == EXIT_ERROR, err
    assert "bug in netdae" not in err
    assert "i1 drives a net DC current of -1 A into node 'a'" in err and "add a resistor from node 'a'" in err


@pytest.mark.parametrize("command", ["run", "sweep"])
def test_out_naming_a_file(capsys, tmp_path, command):
    """--out onto a file: said in words (was '[Errno 17] File exists'); the sweep checks it before its rows run."""
    blocker = tmp_path / "blocker"
    blocker.write_text("")
    text = "t\nv1 in 0 1\nr1 in out 1k\nc1 out 0 1u\n.tran 1u 10u\n.meas tran x max v(out)\n.end\n"
    extra = ["--step", "r1=1k,2k", "--workers", "1"] if command == "sweep" else []
    status, err, _ = _cli(capsys, tmp_path, text, command, "-q", "--out", str(blocker), *extra)
    assert status == EXIT_ERROR, err
    assert err == f"netdae: error: cannot write {blocker}: --out names a file, not a directory (hint: give a " \
                  "directory, which netdae creates if it does not exist)\n"
    status, err, _ = _cli(capsys, tmp_path, text, command, "-q", "--out", str(blocker / "sub"), *extra)
    assert status == EXIT_ERROR and "a part of the path is a file, not a directory" in err, err


def test_differential_voltage_written_to_csv(capsys, tmp_path):
    """--save v(in,out): the CSV header quotes the name holding a comma (was refused: 'contains a separator')."""
    text = "t\nv1 in 0 1\nr1 in out 1k\nr2 out 0 3k\n.op\n.dc v1 0 2 1\n.end\n"
    status, err, _ = _cli(capsys, tmp_path, text, "run", "-q", "--save", "v(in,out),v(out)", "--out",
                          str(tmp_path / "o"))
    assert status == 0, err
    dc = tmp_path / "o" / "dc.csv"
    assert dc.read_text().splitlines()[0] == 'v1,"v(in,out)",v(out)'
    res = read_csv(dc)
    np.testing.assert_allclose(res.signals["v(in,out)"], 0.25 * res.axes["v1"], rtol=1e-9)  # divider 1k : 3k
    op = read_csv(tmp_path / "o" / "op.csv")
    assert op.signals["v(in,out)"][0] == pytest.approx(0.25, rel=1e-9)


API_RC = "rc\nV1 in 0 1\nR1 in out 1k\nC1 out 0 1u\n.op\n.end\n"


@pytest.mark.parametrize("call, message", [
    (lambda: netdae.load(API_RC, params="r=1"), r"params must be a mapping of parameter names to values"),
    (lambda: netdae.load(API_RC, params=[("r", 1)]), r"params must be a mapping .* not list"),
    (lambda: netdae.load(API_RC, max_elements="10"), r"max_elements must be an integer, not str"),
    (lambda: netdae.run(API_RC, save=[3]), r"save must hold strings, not int"),
    (lambda: netdae.run(API_RC, save=3), r"save must be a string or a list of strings, not int"),
    (lambda: netdae.run(API_RC, reltol="1e-3"), r"reltol must be a number, not str"),
    (lambda: netdae.run(API_RC, abstol=np.array([1e-12, 1e-9])), r"abstol must be a number, not ndarray"),
    # a callback that is not callable: refused before the work, not when first called after it
    (lambda: netdae.run(API_RC, progress=3), r"progress must be a function called as progress\(t, tstop, steps\)"),
    (lambda: netdae.simulate(API_RC.replace(".op", ".tran 1u 1m"), progress="bar"), r"not str \('bar'\)"),
    (lambda: netdae.run(API_RC.replace(".op", ".tran 1u 1m"), output=5),
     r"output must be a function called as output\(position, start, block\), not int \(5\)"),
    (lambda: netdae.sweep(API_RC, params={"r1": [1e3]}, save=["v(out)"], progress=3), r"progress must be a function called as progress\(done, total\), not int"),
])
def test_api_arguments_of_the_wrong_type(call, message):
    """Wrong argument types are TypeErrors that say what is expected (were AttributeErrors from inside, or a
    numpy UFuncTypeError from the Newton iteration for reltol='1e-3')."""
    with pytest.raises(TypeError, match=message):
        call()


@pytest.mark.parametrize("kw, message", [
    ({"at": "x"}, r"^at must be 'op' or 't0', not 'x'$"),  # was '--at must be', the command line's option
    ({"method": "x"}, r"^method must be auto, kronecker, topological or sparse, not 'x'$"),
])
def test_analyze_index_names_its_own_arguments(kw, message):
    with pytest.raises(netdae.NetdaeError, match=message):
        netdae.analyze_index(API_RC, **kw)


@pytest.mark.parametrize("limit", [0, -1])
def test_a_limit_of_no_elements_is_refused_as_such(limit):
    """max_elements=-1 was 'the expanded circuit would have 3 elements, more than the limit of -1'."""
    with pytest.raises(ValueError, match=rf"^max_elements must be a positive integer \(a limit on the expanded "
                                         rf"circuit's elements\), not {limit}$"):
        netdae.load(API_RC, max_elements=limit)


def test_an_absolute_tolerance_below_what_the_error_test_meets_is_refused(tmp_path):
    """.options abstol=1e-30 (ngspice takes it) failed 'error test failed 10 times at t=0' blaming the solution's
    smoothness, and abstol=1e-200 made a singular Newton matrix (compiled) or a ZeroDivisionError reported as a
    bug (Python engine): the weight of a current at 0 A is 1/abstol. Refused below 1e-20 with the reason, at the
    value; 1e-20 itself runs (the step from 0 A passes down to about 1e-25)."""
    rc = "t\nV1 a 0 pulse(0 1 0 1n 1n 1u 2u)\nR1 a b 1k\nC1 b 0 1n\n{opt}.tran 10n 10u\n.end\n"
    with pytest.raises(NetlistError, match=r"abstol=1e-30 is out of range .*from 1e-20") as err:
        netdae.simulate(rc.format(opt=".options abstol=1e-30\n"))
    assert (err.value.location.line, err.value.location.column) == (5, 17)
    with pytest.raises(ValueError, match=r"abstol=1e-200: expected a current tolerance in amperes from 1e-20"):
        netdae.simulate(rc.format(opt=""), abstol=1e-200)
    with pytest.raises(ValueError, match=r"vntol=1e-21: expected a voltage tolerance"):
        netdae.simulate(rc.format(opt=""), vntol=1e-21)
    fine = netdae.simulate(rc.format(opt=".options abstol=1e-20\n"), save=["v(b)"])
    ref = netdae.simulate(rc.format(opt=""), save=["v(b)"], reltol=1e-6)
    assert fine.ok
    assert np.max(np.abs(np.interp(ref.t, fine.t, fine["v(b)"]) - ref["v(b)"])) < 1e-2


def test_one_string_saved_is_one_signal():
    """run(save="v(out)") saves v(out), as netdae.sweep(save="v(out)") does (it was a TypeError in run only)."""
    (res,) = netdae.run(API_RC, save="v(out)")
    assert res.names() == ["v(out)"]
    assert res["v(out)"][0] == pytest.approx(1.0, rel=1e-12)


def test_sweep_command_step_given_twice(capsys, tmp_path):
    """--step r1=1,2 --step R1=3,4: the first was dropped without a word (a dict of the two)."""
    text = "t\nv1 in 0 1\nr1 in out 1k\nc1 out 0 1u\n.tran 1u 10u\n.meas tran x max v(out)\n.end\n"
    status, err, _ = _cli(capsys, tmp_path, text, "sweep", "-q", "--out", str(tmp_path / "o"), "--step", "r1=1,2",
                          "--step", "R1=3,4", "--workers", "1")
    assert status == EXIT_ERROR, err
    assert err.startswith("netdae: error: --step r1 is given twice (hint: give all its values in one --step")
    assert not (tmp_path / "o").exists()


def test_pulse_train_cut_by_a_fractional_pulse_count():
    """PULSE(... np=1.5) ends the train at td + 1.5 per, inside the second pulse (ngspice cuts it there too): the
    cut is a breakpoint now (the transient failed there: 'step size below the roundoff of t'); the response
    equals that of the same waveform written as a PWL with the jump."""
    rc = "t\nV1 a 0 {src}\nR1 a b 1k\nC1 b 0 1n\n.tran 10n 6u\n.end\n"
    pulse = netdae.simulate(rc.format(src="pulse(0 1 0.5u 1n 1n 1u 2u 1.5)"), save=["v(b)"], reltol=1e-6)
    pwl = netdae.simulate(rc.format(src="pwl(0 0 0.5u 0 0.501u 1 1.501u 1 1.502u 0 2.5u 0 2.501u 1 3.5u 1 3.5u 0)"),
                          save=["v(b)"], reltol=1e-6)
    t = np.linspace(0.0, 6e-6, 601)
    a = np.interp(t, pulse.t, pulse["v(b)"])
    b = np.interp(t, pwl.t, pwl["v(b)"])
    assert np.max(np.abs(a - b)) < 2e-4  # the two runs' own errors (reltol 1e-6) and the linear interpolation
    assert np.interp(5e-6, pulse.t, pulse["v(b)"]) == pytest.approx(
        np.interp(3.5e-6, pulse.t, pulse["v(b)"]) * math.exp(-1.5), rel=1e-3)  # decays with RC = 1 us after it


@pytest.mark.parametrize("engine", ["compiled", "python"])
def test_pulse_longer_than_its_period_is_a_sawtooth(engine, monkeypatch):
    """PULSE(0 1 0 1n 1n 1u 1n): the rise outlasts the period, so (as ngspice reads it) every period is a ramp
    from 0 cut at 1 ns, a jump back to 0 at each td + k per. Both engines failed at t = 3 ns ('step size below
    the roundoff of t'): floor(tau/per) put the jump a few ulps from the breakpoint td + k per, and the corners
    of a cut pulse (base + tr, 2 ulps past the next base) were breakpoints too. Against the closed form of an
    RC driven by the sawtooth (at each period's end v <- exp(-a) v + 1 - (1 - exp(-a))/a, a = per/RC)."""
    from netdae.netlist.waveforms import Pulse

    monkeypatch.setenv("NETDAE_ENGINE", engine)
    P = np.array([[0.0], [1.0], [0.0], [1e-9], [1e-9], [1e-6], [1e-9], [0.0]])
    bps = np.unique(Pulse._breakpoints(P, np.array([0.0]), np.array([1e-6])))
    assert bps.size >= 1000 and np.all(np.diff(bps) > 0.9e-9)  # one per period, nothing ulps apart
    p = tuple(P[:, 0])
    # at td + per the first period's end (ngspice reduces tau only when tau > per), later the next period's start
    assert Pulse._value_scalar(p, bps[1]) == 1.0 == Pulse._value(P, np.array([bps[1]]))[0]
    for b in bps[2:]:
        assert Pulse._value_scalar(p, b) == 0.0 == Pulse._value(P, np.array([b]))[0]
        assert Pulse._value_scalar(p, np.nextafter(b, -1.0)) > 1.0 - 1e-5  # the ramp's end just before it
    rc = "t\nV1 a 0 pulse(0 1 0 1n 1n 1u 1n)\nR1 a b 1k\nC1 b 0 1n\n.tran 10n 1u\n.end\n"
    res = netdae.simulate(rc, save=["v(b)"], reltol=1e-6)
    a = 1e-9 / 1e-6
    v = 0.0
    for _ in range(1000):
        v = math.exp(-a) * v + 1.0 - (1.0 - math.exp(-a)) / a
    assert res.t[-1] == pytest.approx(1e-6)
    # two steps a period, each restarting at order 1 after the jump: local errors of ~1e-6 add up over the 2,000
    # steps (the global error of a per-step error control, ~2e-4 here; 0.25 V at reltol 1e-3, ngspice 0.08 V)
    assert abs(res["v(b)"][-1] - v) < 2000 * (1e-6 * v + 1e-6)


def test_impulses_of_a_square_wave_are_noted_a_few_times(capsys, tmp_path):
    """A square wave across a capacitor (index 2) puts an impulse into i(v1) at every edge: one warning line each
    flooded the terminal (12,000 lines for a fast pulse train); three are shown, the rest counted, all kept."""
    text = ("t\nv1 a 0 pwl(0 0 0.5u 0 0.5u 1 1u 1 1u 0) r=0\nc1 a 0 1n\nr1 a 0 1k\n.tran 10n 20u\n.end\n")
    status, err, _ = _cli(capsys, tmp_path, text, "run", "-q", "--out", str(tmp_path / "o"))
    lines = err.splitlines()
    assert sum("contains an impulse (Dirac delta) in i(v1)" in line for line in lines) == 3, err
    more = [line for line in lines if "more breakpoints where the inputs jump put impulses" in line]
    assert len(more) == 1 and "(the last at t=1.95e-05; all in transient.impulses)" in more[0], err
    res = netdae.simulate(text, save=["i(v1)"])
    assert len(res.transient.impulses) == int(more[0].split("warning: ")[1].split(" more")[0].replace(",", "")) + 3


@pytest.mark.skipif(__import__("netdae.ngspice.shared", fromlist=["library_path"]).library_path() is None,
                    reason="ngspice's shared library is not installed")
def test_ctrl_c_while_ngspice_runs_in_its_shared_library(tmp_path):
    """Ctrl-C during 'netdae compare' while ngspice's background thread ran: the circuit was removed under the
    running thread, and the process died by SIGSEGV (status -11, two runs in three) after 'interrupted'; the
    thread is halted first now, and the interrupt comes out as KeyboardInterrupt."""
    import os
    import signal
    import subprocess
    import sys
    import time

    child = tmp_path / "child.py"
    child.write_text(
        "import sys\nfrom netdae.ngspice import shared\n"
        "netlist = 'long\\nV1 a 0 sin(0 1 1k)\\nR1 a b 1k\\nC1 b 0 1u\\nD1 b 0 dm\\n.model dm d\\n"
        ".tran 1n 50m\\n.end\\n'\n"
        "shared.version()\nprint('loaded', flush=True)\n"
        "try:\n    shared.run(netlist, timeout=None)\nexcept KeyboardInterrupt:\n    sys.exit(130)\n")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    proc = subprocess.Popen([sys.executable, str(child)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env=env, preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    assert proc.stdout.readline().strip() == "loaded"
    time.sleep(2.0)  # ngspice's thread is integrating (the run takes minutes)
    proc.send_signal(signal.SIGINT)
    try:
        _, err = proc.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        proc.kill()
        raise
    assert proc.returncode == 130, (proc.returncode, err[-2000:])


def test_initial_condition_a_source_overrides_is_named(capsys, tmp_path):
    """.ic v(a)=5 at a node V1 fixes to 1 V: the transient starts at 1 V, as in ngspice, and a warning says the
    value was not held (it was dropped without a word); a value a resistor pulls on is held (no warning)."""
    text = "t\nV1 a 0 1\nR1 a b 1m\nC1 b 0 1u\n.ic v(a)=5 v(b)=2\n.tran 1n 1u\n.end\n"
    status, err, path = _cli(capsys, tmp_path, text, "run", "-q", "--out", str(tmp_path / "o"))
    assert status == 0, err
    assert err == (f"netdae: warning: {path}:5:7: .ic v(a)=5 is not held: v(a) = 1 at t = 0, which v1 (voltage "
                   "source) fixes (hint: drop the .ic of v(a), or change v1's value)\n")
    res = netdae.simulate(text, save=["v(a)", "v(b)"])
    assert res["v(a)"][0] == 1.0 and res["v(b)"][0] == pytest.approx(2.0, rel=1e-6)


@pytest.mark.parametrize("uic", ["", " uic"])
def test_initial_condition_across_a_chain_of_sources_names_them(capsys, tmp_path, uic):
    """.ic v(a)=5 where V1 + V2 fix v(a) = 3 V: with or without uic the start is 3 V (the sources hold), and the
    warning at the .ic value names both sources and the value used."""
    text = f"t\nV1 a b 1\nV2 b 0 2\nC1 a 0 1u\nR1 a 0 1k\n.ic v(a)=5\n.tran 1u 10u{uic}\n.end\n"
    status, err, path = _cli(capsys, tmp_path, text, "run", "-q")
    assert status == 0, err
    when = " by the uic start" if uic else ""
    assert (f"{path}:6:7: .ic v(a)=5 is not held{when}: v(a) = 3 at t = 0, which v1 (voltage source), v2 (voltage "
            "source) fix (in series from the node to ground) (hint: drop the .ic of v(a), or change v1's value)") in err
    res = netdae.simulate(text, save=["v(a)"])
    assert res["v(a)"][0] == pytest.approx(3.0, rel=1e-12)


def test_uic_initial_condition_of_a_node_no_capacitor_holds_is_named(capsys, tmp_path):
    """uic with .ic v(b)=3 on a resistive divider: b follows from its current law (0.5 V), said at the .ic value."""
    text = "t\nV1 a 0 1\nR1 a b 1k\nR2 b 0 1k\nC1 a 0 1u\n.ic v(b)=3\n.tran 1u 10u uic\n.end\n"
    status, err, path = _cli(capsys, tmp_path, text, "run", "-q")
    assert status == 0, err
    assert (f"{path}:6:7: .ic v(b)=3 is not held by the uic start: v(b) = 0.5 at t = 0, which the circuit's "
            "equations fix there (no capacitor alone holds v(b); elements at b: r1, r2) (hint: give .ic values only "
            "to nodes a capacitor holds, or leave out uic to start from the operating point)") in err
    assert netdae.simulate(text, save=["v(b)"])["v(b)"][0] == pytest.approx(0.5, rel=1e-9)


def test_initial_condition_given_twice_is_a_warning_at_the_second(capsys, tmp_path):
    """The last value holds, as in ngspice (measured: v(b)[0] = 2); netdae says one was replaced."""
    text = "t\nV1 a 0 1\nR1 a b 1k\nC1 b 0 1u\n.ic v(b)=1 v(b)=2\n.tran 1u 10u\n.end\n"
    status, err, path = _cli(capsys, tmp_path, text, "run", "-q")
    assert status == 0, err
    assert (f"{path}:5:14: .ic: v(b) is given twice: 2 here replaces 1 (at {path}:5:7) (the last value holds, "
            "as in ngspice)") in err
    assert netdae.simulate(text, save=["v(b)"])["v(b)"][0] == pytest.approx(2.0, rel=1e-6)


@pytest.mark.parametrize("command", ["check", "run", "index"])
def test_initial_condition_on_a_missing_node_through_every_command(capsys, tmp_path, command):
    text = "t\nV1 a 0 1\nR1 a b 1k\nC1 b 0 1u\n.ic v(zz)=2\n.tran 1u 10u\n.end\n"
    status, err, path = _cli(capsys, tmp_path, text, command)
    assert status == EXIT_ERROR and "bug in netdae" not in err and "Traceback" not in err
    assert f"{path}:5:7: .ic: unknown node 'zz'" in err and "hint: subcircuit nodes are named" in err


@pytest.mark.parametrize("command", ["run", "index"])
@pytest.mark.parametrize("instance, shown", [("m=-1", "m = -1"), ("area=0", "area = 0")])
def test_diode_multiplicity_or_area_not_positive_is_located(capsys, tmp_path, command, instance, shown):
    """As the JFET's, MESFET's and VDMOS's: at the element's card, with the value (it was neither)."""
    text = f"t\nV1 a 0 1\nR1 a b 1k\nD1 b 0 dd {instance}\n.model dd d\n.op\n.end\n"
    status, err, path = _cli(capsys, tmp_path, text, command)
    assert status == EXIT_ERROR and "bug in netdae" not in err
    assert f"{path}:4:1: d1: {shown} must be positive (hint: give" in err


#: An instance of each family that takes a multiplier (and the BJT's areas), with its model card.
_SCALED = {
    "bjt": ("Q1 b a 0 qn {}", ".model qn npn"),
    "mos1": ("M1 b a 0 0 nm {}", ".model nm nmos level=1"),
    "mos2": ("M1 b a 0 0 nm {}", ".model nm nmos level=2"),
    "mos3": ("M1 b a 0 0 nm {}", ".model nm nmos level=3 nsub=1e16"),
    "diode": ("D1 b 0 dd {}", ".model dd d"),
    "jfet": ("J1 b a 0 jm {}", ".model jm njf"),
    "mesa": ("Z1 b a 0 zm l=1u w=10u {}", ".model zm nmf level=2"),
    "hfet": ("Z1 b a 0 hm l=1u w=10u {}", ".model hm nhfet level=5"),
    "vdmos": ("M1 b a 0 vm {}", ".model vm vdmos"),
}


@pytest.mark.parametrize("family, instance, shown", [
    ("bjt", "m=0", "m = 0"), ("bjt", "m=-1", "m = -1"), ("bjt", "area=0", "area = 0"), ("bjt", "area=-2", "area = -2"),
    ("mos1", "m=0", "m = 0"), ("mos1", "m=-1", "m = -1"), ("mos2", "m=0", "m = 0"), ("mos3", "m=-1", "m = -1"),
    ("diode", "m=0", "m = 0"), ("jfet", "m=-1", "m = -1"), ("mesa", "m=0", "m = 0"), ("hfet", "m=-1", "m = -1"),
    ("vdmos", "m=0", "m = 0"),
])
def test_a_multiplier_or_area_not_positive_is_located_in_every_family(capsys, tmp_path, family, instance, shown):
    """ngspice 39 runs m=0 as a device that conducts nothing and m=-1 as one whose currents are reversed (BJT,
    MOSFET levels 1-3, diode, JFET: checked with ngspice -b); netdae refuses them at the instance's card, with
    what ngspice does in the hint (the BJT and the MOSFETs took them silently)."""
    card, model = _SCALED[family]
    text = f"t\nV1 a 0 1\nR1 a b 1k\n{card.format(instance)}\n{model}\n.op\n.end\n"
    status, err, path = _cli(capsys, tmp_path, text, "run")
    assert status == EXIT_ERROR and "bug in netdae" not in err and "Traceback" not in err
    assert f"{path}:4:1: {card[:2].lower()}: {shown} must be positive (hint: give {shown.split()[0]} a positive" in err
    if shown.startswith(("m ", "area ")):
        assert "ngspice 39 runs" in err and "currents are reversed" in err


@pytest.mark.parametrize("elements, warning, signal, used", [
    # a capacitor across a source: its ic= contradicts the source, which holds (v(a) = 1)
    ("V1 a 0 1\nC1 a 0 1u ic=2\nR1 a 0 1k\n",
     "3:1: c1: ic=2 is not held by the uic start: v(a) = 1 at t = 0, which the loop of v1 with c1 fixes", "v(a)", 1.0),
    # two capacitors in a loop with a source: the loop fixes the sum, the charge at b the split (1/2, 1/2)
    ("V1 a 0 1\nC1 a b 1u ic=0.3\nC2 b 0 1u ic=0.3\nR1 b 0 1meg\n",
     "4:1: c2: ic=0.3 is not held by the uic start: v(b) = 0.5 at t = 0, which the loop of c1, v1 with c2 fixes",
     "v(b)", 0.5),
    # an inductor in series with a current source: the source's current holds
    ("I1 0 a 1m\nL1 a b 1m ic=2m\nC1 b 0 1u\n",
     "3:1: l1: ic=0.002 is not held by the uic start: i(l1) = 0.001 at t = 0, which the current sources and "
     "inductors at its nodes (i1) fix", "i(l1)", 1e-3),
])
def test_uic_element_initial_conditions_a_loop_or_cutset_fixes_are_named(capsys, tmp_path, elements, warning,
                                                                         signal, used):
    text = f"t\n{elements}.tran 1u 10u uic\n.end\n"
    status, err, path = _cli(capsys, tmp_path, text, "run", "-q")
    assert status == 0, err
    assert f"{path}:{warning} (hint: drop ic=" in err
    assert netdae.simulate(text, save=[signal])[signal][0] == pytest.approx(used, rel=1e-6)


def test_an_initial_condition_the_circuit_overrides_leaves_no_forcing_current_in_the_start():
    """.ic v(out)=5 on an ideal differentiator's output, which the op-amp fixes: the operating point first held
    it with the 1e10 S forcing, whose 5e10 A stayed in i(e1) and, through the hidden-constraint correction,
    moved v(in) (fixed by V1 at 0) to 0.0068 V and v(out) to -6.3047. The start is the closed form:
    v(out) = -R C dv(in)/dt = -2 pi (1k * 1u * 1 kHz * 1 V), v(in) = 0, i(e1) = -i(v1) = C dv/dt."""
    text = ("ic on an op-amp output\nV1 in 0 SIN(0 1 1k)\nC1 in m 1u\nR1 m out 1k\nE1 out 0 0 m OPAMP\n"
            ".ic v(out)=5\n.tran 1u 1m\n.end\n")
    res = netdae.simulate(text, save=["v(in)", "v(out)", "i(e1)"])
    assert res["v(in)"][0] == 0.0
    assert res["v(out)"][0] == pytest.approx(-2 * math.pi, rel=1e-6)
    assert res["i(e1)"][0] == pytest.approx(2 * math.pi * 1e-3, rel=1e-6)
    held, moved = [n for n in res.notes if n.startswith("warning: <string>:6:7: .ic v(out)=5 is not held")]
    assert "v(out) = 0 at t = 0, which e1 (ideal op-amp (nullor)) fixes" in held
    assert "by the hidden constraints of the start: v(out) = -6.28319 at t = 0" in moved


def test_an_initial_condition_held_against_a_large_current_is_kept():
    """.ic v(ph)=0 on a 1 F capacitor fed by 2e4 A (1e12 ohm to ground): the forcing conductance (1e10 S) holds the
    node 2 uV off 0 V, which used to count as "not held" (and "no capacitor alone holds v(ph)"), and the transient
    started from the node's DC value without the .ic, 2e16 V. The capacitor holds it: v(ph) = I t / C."""
    text = ("ic against a large current\nI1 0 ph 2e4\nC1 ph 0 1\nR1 ph 0 1e12\n.ic v(ph)=0\n.tran 10n 10u\n.end\n")
    res = netdae.simulate(text, save=["v(ph)"])
    assert abs(res["v(ph)"][0]) <= 2.1e-6
    assert res["v(ph)"][-1] == pytest.approx(2e4 * 10e-6, rel=1e-4)
    assert not [n for n in res.notes if "is not held" in n]


@pytest.mark.parametrize("command", ["run", "index"])
def test_the_command_line_keeps_numpys_floating_point_warnings_quiet(capsys, tmp_path, command):
    """A MESFET at .temp 1e6 overflows numpy's exp in its temperature scaling: the command says in words
    that the equations are not finite, and numpy's RuntimeWarning (with netdae's source line) is not shown."""
    import warnings

    text = ("hot mesfet\nz1 out in 0 mfet l=0.7u w=20u\nrl vdd out 2k\nvdd vdd 0 1.6\nvin in 0 0.5\n"
            ".model mfet nmf level=2 vto=0.15 lambda=0.15\n.temp 1e6\n.op\n.end\n")
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        status, err, _ = _cli(capsys, tmp_path, text, command, "-q")
    assert [str(w.message) for w in seen if issubclass(w.category, RuntimeWarning)] == []
    assert status == EXIT_ERROR and "bug in netdae" not in err
    # run: the operating point's equations "are not finite"; index: the linearisation's "non-finite entries"
    # (a NaN among them was said as "entries of magnitude 0 (above 1e+150 ...)")
    assert ("are not finite at the initial guess" if command == "run" else "has non-finite entries in the "
            "equations of v(out), v(in)") in err, err


def test_a_sin_growing_past_the_largest_double_ends_the_transient_in_words(capsys, tmp_path):
    """SIN with a damping factor of -1e9 grows past 1e308 within a microsecond: the scalar waveform's
    math.exp raised OverflowError ("a bug in netdae"), and the impulse check of the index-2 source current
    then named no unknown at the breakpoints where the input is infinite ("in ;")."""
    text = ("grow\nV1 a 0 sin(0 1 1meg 0 -1e9)\nC1 a 0 1n\nR1 a 0 1k\nV2 b 0 pulse(0 1 1u 1n 1n 1u 4u)\n"
            "C2 b 0 1n\nR2 b 0 1k\n.tran 10n 2u\n.end\n")
    status, err, _ = _cli(capsys, tmp_path, text, "run", "--out", str(tmp_path / "o"))
    assert status == EXIT_FAIL, err
    assert "bug in netdae" not in err and "Dirac delta) in ;" not in err
    assert "BDF failed" in err and "the solution ran away" in err and "points up to t=" in err


def test_an_output_file_name_taken_by_a_directory_is_refused_before_the_run(capsys, tmp_path):
    """--out DIR with DIR/tran.csv a directory: the streamed transient stopped after its first chunk of points (64
    steps, 'nothing was left'); now refused before anything runs, with the file named."""
    (tmp_path / "o" / "tran.csv").mkdir(parents=True)
    text = "rc\nV1 a 0 PULSE(0 1 0 1u 1u 1m 2m)\nR1 a b 1k\nC1 b 0 1u\n.tran 10u 10m\n.end\n"
    status, err, path = _cli(capsys, tmp_path, text, "run", "-q", "--out", str(tmp_path / "o"))
    assert status == 2
    assert err.strip() == (f"netdae: error: cannot write {tmp_path / 'o' / 'tran.csv'}: it is a directory (hint: "
                           "remove or rename it, or give another --out)")
    assert list((tmp_path / "o").iterdir()) == [tmp_path / "o" / "tran.csv"]


@pytest.mark.parametrize("card, analysis, shown, exit_status", [
    ("R2 a 0 1k scale=0", ".op", "temperature factor 1 (tc1, tc2 or tce at its temperature) times scale=0 is 0",
     EXIT_ERROR),
    ("R2 a 0 1k tc1=-0.01 temp=127", ".op", "temperature factor 0 (tc1, tc2 or tce at its temperature) times "
                                             "scale=1 is 0", EXIT_ERROR),
    # the sweep's second point: the first point is kept, the failed analysis's exit status
    ("R2 a 0 1k tc1=-0.01", ".dc temp 100 150 27", "temperature factor 0", 1),
    ("R2 a 0 1k tc1=-0.01", ".dc temp 127 150 23", "temperature factor 0", EXIT_ERROR),  # nothing computed
])
def test_a_resistance_that_scale_or_temperature_make_zero_is_located(capsys, tmp_path, card, analysis, shown,
                                                                     exit_status):
    """R times its temperature factor times scale= of 0 was an infinite conductance: 'internal error:
    ValueError: A has a NaN entry' from the structure's SVD (ngspice 39 prints -inf currents)."""
    status, err, path = _cli(capsys, tmp_path, f"t\nV1 a 0 1\nR1 a 0 1k\n{card}\n{analysis}\n.end\n", "run", "-q",
                             "--out", str(tmp_path / "out"))
    assert status == exit_status and "bug in netdae" not in err, err
    assert f"{path}:4:1: r2: its resistance 1000 ohm times its {shown}" in err
    assert "an infinite or undefined conductance (hint: check the element's scale= and temperature coefficients)" \
        in err


def test_a_failed_start_without_an_operating_point_says_why_there_is_none(capsys, tmp_path):
    """.tran without uic, no operating point (a B source's current sqrt(v(a) - 2) with v(a) = 1: not finite, as
    ngspice's -nan; a level-1 MOSFET at 10,000 degC was the case found, now refused at the element for its PHI):
    the start as with uic that replaces it failed too, and the message began 'uic: could not find values
    consistent ...', naming an option the card does not have and not the operating point's failure."""
    text = "t\nV1 a 0 1\nR1 a b 1k\nB1 b 0 I=sqrt(v(a)-2)\n.tran 1u 10u\n.end\n"
    status, err, _ = _cli(capsys, tmp_path, text, "run", "-q")
    assert status == EXIT_ERROR and "bug in netdae" not in err
    assert err.startswith("netdae: error: no DC operating point (operating point: the circuit equations are not "
                          "finite at the initial guess"), err
    assert ("and the start without one (as with uic: capacitor voltages and inductor currents from their ic= or 0) "
            "failed too: could not find values consistent with the initial capacitor voltages") in err
    assert "(hint: an expression of these elements divides by zero" in err and "error: uic:" not in err
