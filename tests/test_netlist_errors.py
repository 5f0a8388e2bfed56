"""Every netlist error: its message, the line and column of the offending token, the expected form, the hint."""

from __future__ import annotations

import pytest

from netdae.cli import main as cli_main
import netdae
from netdae.errors import NetdaeError, NetlistError
from netdae.netlist import load

# (netlist, message regex, line, the text the column must point at [, its occurrence in the line])
CASES = [
    # elements netdae does not implement
    ("t\nO1 a 0 b 0 lmod\n", r"o1: undefined model 'lmod'", 2, "lmod"),
    ("t\nU1 a b 0 rcmod l=1u\n", r"u1: undefined model 'rcmod'", 2, "rcmod"),
    ("t\nU1 NAND(2) a b c dly\n", r"u1: a U element with '\(' here is a PSpice digital primitive", 2, "("),
    ("t\nA1 a b amod\n", r"'A' \(XSPICE code model\)", 2, "A1"),
    ("t\nZ1 d g s zm\n.model zm nmf level=7\n", r"z1: model zm: MESFET level 7 \(a level ngspice 39 does not know "
     r"either\) is not implemented by netdae", 3, "7"),
    ("t\n?1 a b\n", r"unknown card '\?1'", 2, "?1"),
    # a Unicode space between words: ngspice reads no blank there (one name), so it is refused
    ("t\nV1 in 0 1\nR1 in\u00a0a 1k\n", r"no-break space \(U\+00A0\) in the card", 3, "\u00a0"),
    ("t\nR1 a 0 1k\nR2 a\u2003b 2k\n", r"em space \(U\+2003\)", 3, "\u2003"),
    # dot cards netdae does not implement
    ("t\nR1 a 0 1\n.disto dec 10 1k 100meg\n", r"\.disto: distortion analysis is not supported", 3, ".disto"),
    ("t\nR1 a 0 1\n.noise v(a) v1 dec 10 1 1k\n", r"\.noise: input source 'v1' names no element", 3, "v1"),
    ("t\nR1 a b 1\nR2 b 0 1\n.pz a 0 c 0 vol pz\n", r"\.pz: output node 'c' is not a node", 4, "c"),
    ("t\nR1 b 0 1\n.sens v(a)\n", r"\.sens: output node 'a'", 3, "a"),
    ("t\n.disto dec 10 1 1k\n", r"distortion", 2, ".disto"),
    ("t\nR1 a 0 1\n.tf v(a) v1\n", r"\.tf: input source 'v1' names no element", 3, "v1"),
    ("t\n.step param r 1 2 1\nV1 a 0 1\n", r"no top-level .param defines .r.", 2, "r", 2),
    ("t\n.foo\n", r"unknown dot card '\.foo'", 2, ".foo"),
    ("t\n.subckt s a\n.tran 1u 1m\n.ends\n", r"\.tran is not allowed inside \.subckt s", 3, ".tran"),
    # a missing .ends: the open .subckt is named, not only the card that shows it
    ("t\n.subckt s p q\nR1 p q 1k\n.subckt t p q\nR1 p q 2k\n.ends\nV1 in 0 1\nX1 in 0 s\n.op\n",
     r"\.op is not allowed inside \.subckt s \(line 2\): it acts on the whole circuit", 9, ".op"),
    # a number below the smallest double reads as 0: out of range as 1e400 is
    ("t\nI1 0 a 1\nR1 a 0 1e-400\n", r"r1: value '1e-400' is out of range", 3, "1e-400"),
    ("t\nV1 a 0 1\nC1 a 0 1e-400\n", r"c1: value '1e-400' is out of range", 3, "1e-400"),
    # structure
    ("t\n.subckt s a b\nR1 a b 1\n", r"\.subckt s: no matching \.ends", 2, ".subckt"),
    ("t\n.ends\n", r"\.ends without a matching \.subckt", 2, ".ends"),
    ("t\n.subckt s a\n.ends\n.subckt s b\n.ends\n", r"subcircuit 's' is defined twice", 4, "s b"),
    ("t\n.subckt s a a\n.ends\n", r"port 'a' listed twice", 2, "a", 2),
    ("t\n.subckt s a optional: b=0\n.ends\n", r"'optional:' ports are not read by ngspice 39", 2, "optional:"),
    ("t\n.control\nrun\n", r"\.control block without \.endc", 2, ".control"),
    ("t\n.lib sec\nR1 a 0 1\n", r"\.lib section without \.endl: '\.lib sec' opens a library section named 'sec'",
     2, ".lib"),
    ("t\n.endl\n", r"\.endl without a preceding \.lib", 2, ".endl"),
    ("t\n+ 1k\n", r"continuation line", 2, "+"),
    # nodes and values
    ("t\nR1 a\n", r"r1: expected 2 nodes, found 1", 2, None),
    ("t\nC1 a b\n", r"c1: missing capacitance", 2, None),
    ("t\nL1 a b ic=1\n", r"l1: missing inductance", 2, None),
    ("t\nR1 a b 1k 2k\n", r"expected a model name after the value, found '2k'", 2, "2k"),
    ("t\nR1 a b 1k foo=2\n", r"unknown parameter 'foo' for a resistor", 2, "foo"),
    ("t\nC1 a b 1u ic=1 ic=2\n", r"parameter 'ic' given twice", 2, "ic", 2),
    ("t\nR1 a b ?x\n", r"bad value '\?x'", 2, "?x"),
    ("t\nR1 a b $x\n", r"r1: missing resistance", 2, " $x"),  # '$' after a blank starts a comment
    ("t\nR1 a b {1+}\n", r"r1: expression ends where a value is expected", 2, "}"),
    ("t\nR1 a b {1 +* 2}\n", r"unexpected '\*'", 2, "*"),
    ("t\nR1 a b {2\n", r"r1: unterminated '\{'", 2, "{"),
    ("t\nR1 a b '2\n", r"unterminated quote", 2, "'"),
    ("t\nR1 a b 0\n", r"zero resistance", 2, "0"),
    ("t\nR1 a b {rr}\n", r"r1: unknown parameter 'rr' in value", 2, "{rr}"),
    ("t\nR1 a b {f(1)}\n", r"unknown function 'f'", 2, "{f(1)}"),
    ("t\nR1 a b {1/0}\n", r"cannot evaluate value: division by zero", 2, "{1/0}"),
    ("t\nR1 a b {sqrt(-1)}\n", r"sqrt\(-1\) is undefined", 2, "{"),
    ("t\nR1 a b {1%0}\n", r"r1: cannot evaluate value: 1 % 0 \(the remainder of a division by zero\) is undefined", 2,
     "{"),
    ("t\n.param a={b} b={a}\nR1 x 0 {a}\n", r"parameter cycle: a -> b -> a", 2, "a={b}"),
    ("t\n.param time=1\n", r"'time' is reserved", 2, "time"),
    ("t\n.param a 1\n", r"expected '=' after parameter name 'a'", 2, "1"),
    ("t\n.param a = 1 + 2 b=3\n", r"the value of 'a' contains blanks and another assignment follows", 2, "1"),
    ("t\n.param 1a=1\n", r"bad parameter name '1a'", 2, "1a"),
    ("t\n.func sin(x) {x}\n", r"'sin' is a built-in function", 2, "sin"),
    ("t\n.func f(x) {x}\n.func f(y) {y}\n", r"function 'f' is defined twice", 3, "f(y)"),
    ("t\n.func f(x) {g(x)}\n.func g(x) {f(x)}\nR1 a 0 {f(1)}\n", r"nested deeper than", 4, "{f(1)}"),
    ("t\n.param p={v(a)}\n", r"circuit reference V\(\.\.\.\) is only allowed in behavioural", 2, "v(a)"),
    ("t\nV1 a 0 {time}\n", r"'time' is only available in behavioural", 2, "time"),
    # subcircuits
    ("t\nX1 a b nosuch\n", r"x1: unknown subcircuit 'nosuch'", 2, "nosuch"),
    ("t\n.subckt s a b\n.ends\nX1 a s\n", r"subcircuit 's' has 2 port\(s\) \(a b\), the instance connects 1", 4, "s"),
    ("t\n.subckt s a params: r=1\n.ends\nX1 n s q=2\n", r"subcircuit 's' has no parameter 'q' \(its parameters: r\)",
     4, "2"),
    ("t\n.subckt a p\nX1 p b\n.ends\n.subckt b p\nX1 p a\n.ends\nX1 n a\n",
     r"recursive subcircuit instantiation: a -> b -> a", 6, "a"),
    ("t\nX1\n", r"missing subcircuit name", 2, None),
    ("t\n.subckt s a\nR1 a 0 {q}\n.ends\nX1 n s\n", r"r1: unknown parameter 'q'", 3, "{q}"),
    # models
    ("t\nD1 a 0 nomodel\n", r"d1: undefined model 'nomodel'", 2, "nomodel"),
    ("t\n.subckt s a\n.model dm d\n.ends\nD1 a 0 dm\n", r"undefined model 'dm'", 5, "dm"),
    ("t\nD1 a 0 q\n.model q npn\n", r"model 'q' is of type 'npn', a diode needs d", 2, "q"),
    ("t\nQ1 c b e nomodel\n", r"no model 'nomodel' defined", 2, "nomodel"),
    ("t\nQ1 c b\n", r"expected 3 or 4 nodes and a model name", 2, None),
    ("t\nM1 d g s nm\n.model nm nmos\n", r"expected 4 nodes and a model name", 2, None),
    ("t\n.model dm d\n.model dm d is=2e-14\n", r"model 'dm' is defined twice", 3, "dm"),
    ("t\nD1 a 0 dm\n.model dm d is\n", r"model parameter 'is' needs a value", 3, "is"),
    ("t\nD1 a 0 dm\n.model dm d is=\"big\"\n", r"model parameter 'is' needs a number, found the string", 3,
     '"big"'),
    ("t\nM1 d g 0 0 mm\n.model mm nmos level=4 kappa=0.1\n",
     r"m1: model mm: MOSFET level 4 \(BSIM1 in ngspice\) is not implemented by netdae", 3, "4"),
    ("t\n.model\n", r"expected a model name and type", 2, None),
    ("t\nL1 a 0 lmod\n.model lmod l\n", r"'lmod' is a model: an inductance computed from a model", 2, "lmod"),
    # references
    ("t\nR1 a 0 1\nr1 b 0 2\n", r"r1: duplicate element name 'r1' \(first defined at <string>:2\)", 3, "r1"),
    ("t\nL1 a 0 1m\nR2 b 0 1\nK1 L1 R2 0.5\n", r"'r2' is not an inductor name", 4, "R2"),
    ("t\nL1 a 0 1m\nK1 L1 L2 0.5\n", r"'l2' names no element", 3, "L2"),
    ("t\nL1 a 0 1m\nL2 b 0 1m\nK1 L1 L2 1.5\n", r"coupling factor 1.5 outside \[-1, 1\]", 4, "1.5"),
    ("t\nL1 a 0 1m\nK1 L1 L1 0.5\n", r"inductor 'l1' is named twice", 3, "L1", 2),
    ("t\nL1 a 0 1m\nK1 L1 0.5\n", r"at least two inductor names and a coupling factor", 3, None),
    ("t\nR1 a 0 1\nF1 b 0 r1 2\n", r"'r1' is a resistor, not a voltage source", 3, "r1"),
    ("t\nR1 a 0 1\nH1 b 0 vx 2\n", r"'vx' names no element", 3, "vx"),
    ("t\n.subckt s a\nF1 a 0 v1 1\n.ends\nX1 n s\nV1 n 0 1\n", r"'v1' names no element \(looked for 'v.x1.v1'\)",
     3, "v1"),
    ("t\nR1 a 0 1\nB1 b 0 V=I(r1)\n", r"I\(r1\) names a resistor, which has no branch current", 3, "I(r1)"),
    ("t\nR1 a 0 1\nB1 b 0 V=V(zz)\n", r"V\(zz\): no element connects node 'zz'", 3, "V(zz)"),
    # controlled and behavioural sources
    ("t\nE1 a 0 b\n", r"e1: expected 4 nodes, found 3", 2, None),
    ("t\nE1 a 0 b 0\n", r"missing gain", 2, None),
    ("t\nG1 a 0 b 0 1 2\n", r"unexpected '2'", 2, "2"),
    ("t\nE1 a 0 b 0 opamp 3\n", r"unexpected '3' after OPAMP", 2, "3"),
    ("t\nF1 a 0 2\n", r"expected the name of the controlling voltage source", 2, "2"),
    ("t\nV1 x 0 1\nF1 a 0 v1\n", r"missing gain", 3, None),
    ("t\nE1 a 0 freq {v(b)} = (0, 0, 0)\n", r"the 'FREQ' form of E is not supported", 2, "freq"),
    ("t\nE1 a 0 poly(x) b 0 1\n", r"POLY dimension must be a positive integer", 2, "x"),
    ("t\nE1 a 0 poly(2) b 0 1\n", r"POLY\(2\) needs 4 controlling nodes and at least one coefficient", 2, None),
    # a POLY control no written coefficient multiplies is read all the same, as ngspice reads it
    ("t\nV9 z 0 1\nR9 z 0 1k\nF1 a 0 poly(2) v9 vx 0 1\nR1 a 0 1k\n",
     r"f1: POLY control 'vx' names no element, not a voltage source", 4, "poly"),
    ("t\nV9 z 0 1\nR9 z 0 1k\nH1 a 0 poly(1) vx 1\nR1 a 0 1k\n",
     r"h1: POLY control 'vx' names no element, not a voltage source", 4, "poly"),
    ("t\nV9 z 0 1\nR9 z 0 1k\nE1 a 0 poly(2) z 0 q 0 0 2\nR1 a 0 1k\n",
     r"e1: V\(q\): no element connects node 'q'", 4, "poly"),
    ("t\nV9 z 0 1\nR9 z 0 1k\nG1 0 a poly(1) q 0 1m\nR1 a 0 1k\n",
     r"g1: V\(q\): no element connects node 'q'", 4, "poly"),
    ("t\nB1 a 0 X=1\n", r"expected V=\{expr\} or I=\{expr\} after the nodes", 2, "X"),
    ("t\nB1 a 0 V=\n", r"missing expression", 2, None),
    ("t\nB1 a 0 V=v(a)+\n", r"b1: expression ends where a value is expected", 2, None),
    ("t\n.param p={ddt(1)}\n", r"ddt\(\) \(a time derivative outside a behavioural source\) is not supported", 2, "ddt"),
    ("t\nB1 a 0 V=v(a,b,c)\n", r"malformed V\(\.\.\.\) reference", 2, "v(a,b,c)"),
    # independent sources and waveforms
    # ngspice multiplies a current source's current by m=; netdae said "unexpected 'm'"
    ("t\nI1 0 b 1m m=2\nR1 b 0 1k\n", r"i1: m= \(ngspice's multiplier of a current source's current\) is not "
     r"read by netdae", 2, "m", 2),
    ("t\nV1 a 0 pulse(1)\n", r"PULSE needs at least 2 parameters \(v1 v2\), got 1", 2, "pulse"),
    ("t\nV1 a 0 sin(0 1 2 3 4 5 6)\n", r"SIN takes at most 6 parameters", 2, "sin"),
    ("t\nV1 a 0 exp(0 1 0 -1)\n", r"EXP tau1 must be >= 0", 2, "exp"),
    ("t\nV1 a 0 pwl(0 0 1)\n", r"PWL needs time-value pairs, got 3", 2, "pwl"),
    ("t\nV1 a 0 pwl(0 0 2 1 1 0)\n", r"PWL time points must not decrease: 1 follows 2", 2, "pwl"),
    ("t\nV1 a 0 pwl(0 0 1 1) r=0.5\n", r"repeat time r=0.5 does not match any time point", 2, "pwl"),
    ("t\nI1 a 0 pwl(0 0 1 1) r=0\n", r"PWL r= is not available on current sources", 2, "0", 4),
    ("t\nV1 a 0 pulse(0 1\n", r"PULSE\( without a closing '\)'", 2, "pulse"),
    ("t\nV1 a 0 1 2\n", r"unexpected '2'", 2, "2"),
    ("t\nV1 a 0 dc\n", r"missing value after 'dc'", 2, None),
    ("t\nV1 a 0 dc 1 dc 2\n", r"DC value given twice", 2, "dc", 2),
    ("t\nV1 a 0 sin(0 1) pulse(0 1)\n", r"more than one transient function", 2, "pulse"),
    ("t\nV1 a 0 external\n", r"'external' \(external source\) is not supported", 2, "external"),
    ("t\nV1 a 0 trnoise(1n)\n", r"TRNOISE needs at least 2 parameters \(na nt\), got 1", 2, "trnoise"),
    ("t\nV1 a 0 trnoise(1n 0)\n", r"TRNOISE NT \(the sampling interval\) is 0: .* give NT > 0", 2, "trnoise"),
    ("t\nV1 a 0 dc 1 trnoise(-1n 1n)\n", r"TRNOISE NA must be >= 0, got -1e-09", 2, "trnoise"),
    ("t\nV1 a 0 trnoise(0 1n 2.5 1n)\n", r"TRNOISE NALPHA \(the 1/f exponent\) must be in \[0, 2\]", 2, "trnoise"),
    ("t\nI1 a 0 trnoise 0 0 0 0 1m 0 1u\n", r"RTSCAPT and RTSEMT .* must be > 0 with RTSAM = 0.001", 2, "trnoise"),
    ("t\nV1 a 0 trnoise(0 1n 0 0 0 0 0 1)\n", r"TRNOISE takes at most 7 parameters", 2, "trnoise"),
    ("t\nV1 a 0 trrandom(5 1u)\n", r"TRRANDOM TYPE must be 1 \(uniform\), 2 .* got 5", 2, "trrandom"),
    ("t\nI1 a 0 trrandom(1 0)\n", r"TRRANDOM TS \(the time a value is held\) must be > 0, got 0", 2, "trrandom"),
    ("t\nV1 a 0 trrandom(2 1u -1)\n", r"TRRANDOM TD \(the delay\) must be >= 0", 2, "trrandom"),
    ("t\nV1 a 0 trrandom(3 1u 0 0)\n", r"TRRANDOM type 3: PARAM1 \(the mean\) must be > 0, got 0", 2, "trrandom"),
    ("t\nV1 a 0 trrandom(4 1u 0 -2)\n", r"TRRANDOM type 4: PARAM1 \(lambda, the mean\) must be >= 0", 2,
     "trrandom"),
    # what ngspice's own example netlists use and netdae does not have, named
    ("t\nM1 d g s b vd\n.model vd vdmos\n", r"model 'vd' is a VDMOS \(power MOSFET\): its M card has three "
     r"nodes", 2, "vd"),
    ("t\nM1 d g 0 tj tc irf thermal\n.model irf vdmos\n", r"a self-heating VDMOS .* with thermal nodes "
     r"\('thermal'\) is not supported", 2, "thermal"),
    ("t\nD1 1 0 tj dm thermal\n.model dm d\n", r"a self-heating diode with thermal nodes \('thermal'\) is not "
     r"supported", 2, "thermal"),
    ("t\nQ1 c b 0 s tj qm\n.model qm npn\n", r"q1: 5 nodes \(with a thermal node\) need a self-heating model; "
     r"model qm is npn level 1", 2, "Q1"),
    ("t\nB1 1 0 V=v(2)*2 tc1=1m reciprocm=1\n", r"reciprocm= on a B source \(multiplier\) is not supported", 2,
     "reciprocm"),
    ("t\nB1 1 0 V=(v(2)>1) | (v(2)<0)\n", r"'\|' \(PSpice's logical or\) is not supported by netdae", 2, "|"),
    ("t\n.param p={(1>0) & (2>1)}\n", r"'&' \(PSpice's logical and\) is not supported by netdae", 2, "&"),
    ("t\nS1 1 0 2 0 sm\n.model sm vswitch(ron=1)\n", r"model 'sm' is of type 'vswitch', PSpice's voltage-controlled "
     r"switch \(ngspice's sw\), which netdae does not support", 2, "sm"),
    ("t\nQ1 c b 0 qp\n.model qp ako:q350 pnp(bf=50)\n.model q350 pnp\n", r"model 'qp' is a PSpice AKO model "
     r"\('a kind of' q350\), which netdae does not support", 2, "qp"),
    ("t\n.func f(x) = {x*v(a)}\nR1 a 0 1\n.param p = f(2)\n", r"\.param: cannot evaluate parameter 'p': function "
     r"f\(\) reads the circuit \(v\(a\), \.func at <string>:2\)", 4, "f(2)"),
    ("t\n.func f(x) = {x*ddt(v(a))}\n", r"ddt\(\) in a \.func body is not supported by netdae", 2, "x*ddt"),
    ("t\nB1 1 0 V=~(v(2)>1)\n", r"'~' \(PSpice's logical not\) is not supported by netdae", 2, "~"),
    # analyses and control cards
    ("t\n.tran 1u\n", r"expected tstep and tstop, found 1 value", 2, None),
    ("t\n.tran 0 1m\n", r"tstep must be > 0, got 0", 2, "0"),
    ("t\n.tran 1u -1m\n", r"tstop must be > 0", 2, "-1m"),
    ("t\n.tran 1u 1m 2m\n", r"tstart must be in \[0, tstop\), got 0.002", 2, "2m"),
    ("t\n.tran 1u 1m 0 0 0 0\n", r"too many values", 2, "0", 3),
    ("t\n.ac dek 10 1 1k\n", r"expected the sweep type dec, oct or lin", 2, "dek"),
    ("t\n.ac dec 10 1\n", r"expected points, fstart and fstop, found 2", 2, None),
    ("t\n.ac dec 2.5 1 1k\n", r"points must be a positive integer, got 2.5", 2, "2.5"),
    ("t\n.ac dec 10 0 1k\n", r"fstart must be > 0", 2, "0", 2),
    ("t\n.ac lin 10 1k 1\n", r"fstop 1 is below fstart 1000", 2, "1", 3),
    ("t\n.dc v1 0 1\n", r"expected one or two sweeps of 4 items", 2, None),
    ("t\nR1 a 0 1\n.dc r1 0 1 0.1\n", r"a resistance sweep from 0 to 1 reaches 0 ohm", 3, "0"),
    ("t\nC1 a 0 1\n.dc c1 1 2 0.1\n", r"sweep source 'c1' is a capacitor", 3, "c1"),
    ("t\n.dc vx 0 1 0.1\n", r"sweep source 'vx' is no element", 2, "vx"),
    ("t\nV1 a 0 1\n.dc v1 0 1 -0.1\n", r"step -0.1 does not lead from 0 to 1", 3, "-0.1"),
    ("t\n.dc 1 0 1 0.1\n", r"expected a source name or temp", 2, "1"),
    ("t\nV1 a 0 1\nR1 a 0 1\n.dc v1 0 1 0.1 V1 0 1 0.5\n", r"'v1' is swept twice: the outer sweep would "
     r"overwrite", 4, "V1"),
    ("t\nR1 a 0 1\n.dc temp 0 10 5 temp 0 10 5\n", r"'temp' is swept twice", 3, "temp", 2),
    ("t\nR1 a 0 1\n.ic v(b)=1\n", r"\.ic: unknown node 'b'", 3, "b"),
    ("t\nR1 a 0 1\n.ic a=1\n", r"expected v\(node\)=value, found 'a'", 3, "a"),
    ("t\nR1 a 0 1\n.nodeset v(a)\n", r"expected v\(node\)=value", 3, "v"),
    ("t\n.options reltol\n", r"option 'reltol' needs a number", 2, "reltol"),
    ("t\n.options reltol=-1\n", r"option 'reltol' must be > 0", 2, "-1"),
    ("t\n.options maxord=2.5\n", r"option 'maxord' needs a positive integer", 2, "2.5"),
    ("t\n.options method=euler\n", r"unknown integration method 'euler'", 2, "method"),
    ("t\n.temp\n", r"expected a temperature", 2, None),
    ("t\n.op 1\n", r"unexpected '1'", 2, "1"),
    # a quoted value on an instance: it was 'missing value after r=' although a value is there
    ("t\nV1 a 0 1\nR1 a 0 r=\"1k\"\n", r"'r=' takes a number or an expression, not the string '1k'", 3, '"1k"'),
    ("t\nD1 a 0 dd area=\"x\"\n.model dd d\n", r"'area=' takes a number or an expression, not the string 'x'",
     2, '"x"'),
    # files
    ("t\n.include nothere.cir\n", r"include file 'nothere.cir' not found", 2, "nothere.cir"),
    ("t\n.lib nothere.lib fast\n", r"library file 'nothere.lib' not found", 2, "nothere.lib"),
    ("t\n.include\n", r"\.include: missing file name", 2, None),
    ("t\n.lib\n", r"\.lib: missing file name and section", 2, None),
]


def _column(netlist: str, line: int, token: str | None, occurrence: int = 1) -> int:
    text = netlist.split("\n")[line - 1]
    if token is None:
        return len(text) + 1  # a missing item is reported at the end of the card
    index = -1
    for _ in range(occurrence):
        index = text.index(token, index + 1)
    return index + 1


@pytest.mark.parametrize("case", CASES, ids=[c[1][:40] for c in CASES])
def test_error_message_line_and_column(case):
    netlist, pattern, line, token, *occ = case
    with pytest.raises(NetlistError) as exc:
        load(netlist)
    err = exc.value
    assert err.location is not None, str(err)
    assert __import__("re").search(pattern, err.message), err.message
    assert (err.location.file, err.location.line) == ("<string>", line), str(err)
    assert err.location.column == _column(netlist, line, token, *occ), str(err)


def test_analyses_skipped_in_a_control_loop_are_named():
    c = load("t\nR1 a 0 1\nV1 a 0 1\n.control\nop\nlet x = v(a)\nwhile x < 1\n  op\nend\n.endc\n")
    assert len(c.analyses) == 1  # the op before the loop
    c.analyses.clear()
    with pytest.raises(NetdaeError, match=r"nothing to run \(the .control block's analyses are not read: 'op' at "
                                          r"<string>:8:3 was skipped because it follows 'while x < 1' "
                                          r"\(<string>:7:1\), which netdae does not run: netdae cannot evaluate "
                                          r"its condition: vector 'x'"):
        netdae.run(c)


def test_element_errors_show_the_expected_form_and_a_hint():
    with pytest.raises(NetlistError) as exc:
        load("t\nC1 a b\n")
    err = exc.value
    assert err.expected.startswith("Cname n+ n- value [mname] [ic=v0]")
    assert err.hint and str(err).startswith("<string>:2:7: c1: missing capacitance (expected: Cname n+ n- value")
    with pytest.raises(NetlistError) as exc:
        load("t\nA1 a b amod\n")
    assert "netdae reads R C L K V I E G F H B D Q M J Z S W T O Y P U N X" in exc.value.hint


def test_check_command_reports_one_line_and_exit_status_2(tmp_path, capsys):
    bad = tmp_path / "bad.cir"
    bad.write_text("bad netlist\nR1 a 0 1\nC1 a 0\n.end\n")
    assert cli_main(["check", str(bad)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert err.startswith(f"netdae: error: {bad}:3:7: c1: missing capacitance (expected: Cname")


@pytest.mark.parametrize("data, line, column, what", [
    ("t\nR1 a 0 1\n.op\n".encode("utf-16"), 1, 4, "it looks like text saved as UTF-16 or UTF-32"),
    ("t\nR1 a 0 1\n.op\n".encode("utf-16-le"), 1, 2, "it looks like text saved as UTF-16 or UTF-32"),
    (b"t\nR1 a 0 1\n\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR", 5, 1, "it looks like a binary file, not a text netlist"),
    (b"t\nR\x001 a 0 1\n.op\n", 2, 2, "it looks like a binary file, not a text netlist"),
    # an ELF header's second half-words are zeros too: it was called UTF-16 text
    (b"\x7fELF\x02\x01\x01\x00\x00\x00\x00\x00\x00\x00\x00\x00\x03\x00>\x00", 1, 8,
     "it is an ELF executable or shared library (a compiled .osdi model is one: load it with .osdi or pre_osdi), "
     "not a text netlist"),
])
def test_file_with_a_nul_byte_is_refused_at_it(tmp_path, data, line, column, what):
    """UTF-16 text and binary files read as cards of garbage ('unknown card ' v 1 '', a NUL inside an element
    name accepted); a NUL byte is refused where it is, saying what the file seems to be."""
    path = tmp_path / "bad.cir"
    path.write_bytes(data)
    with pytest.raises(NetlistError) as exc:
        load(path)
    err = exc.value
    assert err.message == f"NUL byte in '{path}': {what}"
    assert (err.location.file, err.location.line, err.location.column) == (str(path), line, column)
    top = tmp_path / "top.cir"
    top.write_text("t\n.include bad.cir\nV1 a 0 1\n.op\n")
    with pytest.raises(NetlistError, match="NUL byte in") as exc:
        load(top)
    assert exc.value.location.file == str(path)


@pytest.mark.parametrize("data, line, column, byte", [
    (b"latin1 two nodes\nV1 \xe9 0 1\nR1 \xe9 \xe8 1k\nR2 \xe8 0 1k\n.op\n.end\n", 2, 4, "E9"),
    (b"t\nV1 a 0 1\nR1 a 0 1k\n.control\nprint v(\xe8)\n.endc\n", 5, 9, "E8"),
    (b"t\nV1 a 0 1\nR1 a\n+ b\xff 1k\n.op\n", 4, 4, "FF"),
])
def test_a_byte_that_is_not_utf8_is_refused_at_it(tmp_path, data, line, column, byte):
    """Latin-1 node names became U+FFFD and merged: \xe9 and \xe8 were one node (ngspice 39 refuses the
    file: 'UTF-8 syntax error in line 2')."""
    path = tmp_path / "latin1.cir"
    path.write_bytes(data)
    with pytest.raises(NetlistError) as exc:
        load(path)
    err = exc.value
    assert err.message.startswith(f"byte 0x{byte} is not UTF-8") and "save the file as UTF-8" in err.hint
    assert (err.location.file, err.location.line, err.location.column) == (str(path), line, column)


def test_bytes_that_are_not_utf8_in_comments_and_the_title_are_read_as_ngspice_reads_them(tmp_path):
    path = tmp_path / "latin1.cir"
    path.write_bytes(b"caf\xe9 title\n* r\xe9sistance\nV1 a 0 1\nR1 a 0 2k ; r\xe9sistance\nC1 a 0 1\xb5\n.op\n")
    c = load(path)
    assert c.title == "caf\ufffd title" and not c.diagnostics
    assert c.element("r1").value == 2e3 and c.element("c1").value == pytest.approx(1e-6)


@pytest.mark.parametrize("text, what, name, line, column", [
    ("unicode two\nV1 \u00e9 0 1\nR1 \u00e9 \u00fc 1k\nR2 \u00fc 0 1k\n.op\n", "node", "\u00e9", 3, 4),
    ("unicode case\nV1 a 0 1\nR1 a \u00c4 1k\nR2 \u00e4 0 1k\n.op\n", "node", "\u00c4", 4, 6),
    ("t\nV1 a 0 1\nR\u00e9 a 0 1k\n.op\n", "element", "r\u00e9", 4, 1),
])
def test_a_name_outside_ascii_is_warned_about_once_as_ngspice_reads_it_otherwise(text, what, name, line, column):
    """ngspice 39 reads each byte of a non-ASCII character as '_': \u00e9 and \u00fc are both node '__'."""
    c = load("t\n* caf\u00e9\n" + text.split("\n", 1)[1])
    (w,) = [d for d in c.diagnostics if "outside ASCII" in d.message]
    assert w.severity == "warning" and w.message.startswith(f"{what} name '{name}' has characters outside")
    assert (w.location.line, w.location.column) == (line, column) and "'_'" in w.message
    assert not load("caf\u00e9 \u00fc title\nV1 a 0 1\nR1 a 0 1k ; \u00e9\n* \u00fc\n.op\n").diagnostics


def test_a_file_with_cr_line_ends_only_is_refused_at_line_1(tmp_path):
    """ngspice 39 reads such a file as one title line and simulates nothing; netdae split it and ran."""
    path = tmp_path / "cronly.cir"
    path.write_bytes(b"cr only\rV1 a 0 1\rR1 a 0 2k\r.op\r.end\r")
    with pytest.raises(NetlistError) as exc:
        load(path)
    err = exc.value
    assert (err.location.line, err.location.column) == (1, 8)
    assert "carriage return (CR) alone" in err.message and "one title line (5 lines here)" in err.message
    assert "convert the line endings to LF or CRLF" in err.hint


@pytest.mark.parametrize("char, shown", [("\x01", "0x01, Ctrl-A"), ("\x1c", "0x1C, Ctrl-\\"), ("\x7f", "0x7F, DEL")])
def test_a_control_character_in_a_card_is_refused_at_it(char, shown):
    """R1 a<Ctrl-A>0 1k read as nodes 'a\x010' and '1k' (ngspice 39: node a_0) and ended in 'missing resistance'."""
    with pytest.raises(NetlistError) as exc:
        load(f"t\nV1 a 0 1\nR1 a{char}0 1k\n.op\n")
    assert (exc.value.location.line, exc.value.location.column) == (3, 5)
    assert exc.value.message.startswith(f"a control character ({shown}) in the card: ngspice 39 does not read it "
                                        "as a blank")


def test_a_line_of_ctrl_z_is_skipped_as_ngspice_skips_it():
    """A DOS end-of-file mark (Ctrl-Z) on a line of its own was refused as the unknown card '\x1a', shown as ''."""
    c = load("t\nV1 a 0 1\nR1 a 0 1k\n\x1a\n.op\n")
    assert [e.name for e in c.elements] == ["v1", "r1"] and len(c.analyses) == 1


def test_a_carriage_return_inside_a_line_is_refused_and_crlf_is_read():
    with pytest.raises(NetlistError, match=r"carriage return \(CR\) inside the line") as exc:
        load("t\nV1 a 0 1\nR1 a 0 2k\rR2 a 0 2k\n.op\n")
    assert (exc.value.location.line, exc.value.location.column) == (3, 10)
    lf = load("t\nV1 a 0 1\nR1 a 0 2k\n+ m=2\nR2 a 0 2k\n.op\n")
    for crlf in ("t\r\nV1 a 0 1\r\nR1 a 0 2k\r\n+ m=2\r\nR2 a 0 2k\r\n.op\r\n",
                 "t\r\nV1 a 0 1\r\r\nR1 a 0 2k \r\n+ m=2\r\nR2 a 0 2k\r\n.op"):
        c = load(crlf)
        assert [(e.name, e.nodes, e.value, e.params) for e in c.elements] == \
            [(e.name, e.nodes, e.value, e.params) for e in lf.elements]


def test_endless_include_is_refused(tmp_path, monkeypatch):
    """.include /dev/zero read until the machine's memory ran out (23 GB, then the OOM killer)."""
    import os

    from netdae.netlist import reader

    top = tmp_path / "top.cir"
    if os.path.exists("/dev/zero"):
        top.write_text("t\n.include /dev/zero\nR1 a 0 1\n.op\n")
        with pytest.raises(NetlistError) as exc:
            load(top)
        assert str(exc.value).startswith(f"{top}:2:10: include file '/dev/zero' is larger than 256 MiB (or "
                                         "endless, such as a device)")
    monkeypatch.setattr(reader, "MAX_FILE_BYTES", 100)
    (tmp_path / "big.lib").write_text("* big\n" + "R9 b 0 1\n" * 20)
    top.write_text("t\n.include big.lib\nR1 a 0 1\n.op\n")
    with pytest.raises(NetlistError, match=r":2:10: include file '.*big.lib' is larger than 0 MiB"):
        load(top)


def test_very_long_token_is_shown_by_its_ends():
    """A 200,000-digit number on a very long line: the message shows its ends and its length, not all of it."""
    text = "t\nR1 a 0 " + "1" * 200_000 + "\nV1 a 0 1\n.op\n"
    with pytest.raises(NetlistError) as exc:
        load(text)
    err = exc.value
    assert (err.location.line, err.location.column) == (2, 8)
    assert err.message == "r1: value '" + "1" * 40 + "..." + "1" * 10 + "' (200,000 characters) is out of range"
    assert len(str(err)) < 400


def test_osdi_card_naming_a_directory_or_a_device(tmp_path):
    """'.osdi DIR' said 'does not exist' (wrong blame); the directory or device is named as what it is."""
    (tmp_path / "models").mkdir()
    cases = [(str(tmp_path / "models"), "is a directory")]
    if __import__("os").path.exists("/dev/zero"):
        cases.append(("/dev/zero", "is not a regular file"))
    for target, what in cases:
        with pytest.raises(NetlistError) as exc:
            load(f"t\n.osdi {target}\nN1 a 0 foo\n.model foo bar\nV1 a 0 1\n.op\n", path=str(tmp_path / "t.cir"))
        err = exc.value
        assert err.message == f"OSDI file {target} {what}"
        assert (err.location.line, err.location.column) == (2, 7)


@pytest.mark.parametrize("bv", ["-5", "0"])
def test_a_breakdown_voltage_that_is_not_positive_is_refused_at_the_value(bv):
    # ngspice 39 fails to converge with either (gmin stepping fails; 'timestep too small')
    with pytest.raises(NetlistError, match=rf"model dd: bv={bv} is impossible for a diode.*bv must be > 0") as info:
        netdae.run(f"t\nV1 in 0 -10\nR1 in a 1k\nD1 a 0 dd\n.model dd d is=1e-14 bv={bv}\n.op\n.end\n")
    assert (info.value.location.line, info.value.location.column) == (5, 25)


_PORT_NET = ("t\n.subckt rc in out\nR1 in out 1k\nC1 out mid 1u\nR2 mid 0 1k\n.ends\n"
             "V1 a 0 1\nXa a b rc\nXg b 0 rc\n")


@pytest.mark.parametrize("card, column, written", [
    (".ic v(xa.out)=0.5", 7, "v(b)"),
    (".nodeset v(xa.out)=0.5", 12, "v(b)"),
    (".ic v(xg.out)=0.5", 7, None),
    (".tran 1u 1m\n.meas tran m FIND v(xa.out) AT=1u", 19, "v(b)"),
])
def test_a_subcircuit_port_named_hierarchically_gets_the_node_it_is(card, column, written):
    """``x1.out`` names no node when ``out`` is a port of x1 (the port is the node x1 connects to it,
    ngspice 39 ignores an .ic entry on it with a warning): the hint named hierarchical names, which the
    card already used; it names the node to write."""
    netlist = _PORT_NET + card + "\n"
    with pytest.raises(NetlistError) as exc:
        load(netlist)
    err = exc.value
    assert err.location.line == netlist.count("\n")
    assert err.location.column == column
    assert "is a port of subcircuit instance x" in err.hint, err.hint
    if written is None:  # a port on ground: the name is ground's
        assert "connects ground to it: the name is ground's, 0 V, so leave it out" in err.hint, err.hint
    else:
        assert f"write {written}" in err.hint, err.hint
    # a node inside the instance keeps the hint on hierarchical names
    with pytest.raises(NetlistError) as exc:
        load(_PORT_NET + card.replace(".out", ".nothere") + "\n")
    assert "named hierarchically" in exc.value.hint


def test_a_save_of_a_subcircuit_port_named_hierarchically_names_the_node():
    c = load(_PORT_NET + ".save v(xa.out) v(xa.mid)\n.tran 1u 1m\n")
    text = " ".join(d.message for d in c.diagnostics)
    assert "no node 'xa.out' ('out' is a port of xa, which connects 'b' to it: save v(b))" in text
    assert c.saves == ["v(xa.mid)"]


@pytest.mark.parametrize("ch, what", [("\u2013", "an en dash"), ("\u2212", "a minus sign"), ("\u2014", "an em dash")])
def test_a_typographic_dash_in_a_value_is_named(ch, what):
    """'bad value' without a word on why: the dash a word processor or a PDF makes looks like '-'."""
    with pytest.raises(NetlistError) as exc:
        load(f"t\nV1 a 0 1\nR1 a 0 {ch}1k\n.op\n.end\n")
    assert f"bad value '{ch}1k'" in str(exc.value) and exc.value.location.line == 3
    assert f"'{ch}' (U+{ord(ch):04X}) is {what}, not ASCII '-'" in exc.value.hint


def test_a_greek_mu_after_a_number_is_warned_about():
    """4.7\u03bc (a Greek mu, not the micro sign netdae reads as a scale) was read as 4.7 without a word
    (ngspice ignores it too): a factor of a million."""
    c = load("t\nV1 a 0 1\nR1 a 0 1k\nC1 a 0 4.7\u03bc\n.op\n.end\n")
    (d,) = [d for d in c.diagnostics if "c1" in d.message]
    assert d.location.line == 4 and "read as 4.7" in d.message
    assert "'\u03bc' (U+03BC) is a Greek mu, not ASCII 'u'" in d.message
    assert load("t\nV1 a 0 1\nR1 a 0 1k\nC1 a 0 4.7\u00b5\n.op\n.end\n").element("c1").value == pytest.approx(4.7e-6)
