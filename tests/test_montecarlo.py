"""Monte Carlo functions in netlists: ngspice's conventions, global vs per-instance draws, seeds, errors."""

from __future__ import annotations

import re
import subprocess

import numpy as np
import pytest

from netdae.errors import NetlistError
from netdae.netlist import load
from netdae.netlist.montecarlo import RANDOM_FORMS, Draws

N = 4000


def _many(name, args, n=N, seed=3):
    d = Draws(seed, 0)
    return np.array([d.draw(name, list(args)) for _ in range(n)])


@pytest.mark.parametrize("name, args, mean, std", [
    ("gauss", (10.0, 0.1, 2.0), 10.0, 10.0 * 0.1 / 2.0),      # relative variation / sigma
    ("agauss", (10.0, 0.3, 3.0), 10.0, 0.1),                  # absolute variation / sigma
    ("unif", (10.0, 0.1), 10.0, 1.0 / np.sqrt(3.0)),          # nom +- nom*rvar, uniform
    ("aunif", (-2.0, 0.5), -2.0, 0.5 / np.sqrt(3.0)),         # nom +- avar, uniform
    ("limit", (1.0, 0.25), 1.0, 0.25),                        # nom +- avar, each with probability 1/2
])
def test_distributions_follow_ngspice_conventions(name, args, mean, std):
    x = _many(name, args)
    se = std / np.sqrt(N)
    assert abs(x.mean() - mean) < 4 * se
    # the standard error of a sample standard deviation is about std / sqrt(2 N) (normal); 6 of them
    assert abs(x.std(ddof=1) - std) < 6 * std / np.sqrt(2 * N)
    if name in ("unif", "aunif"):
        half = args[1] * (abs(args[0]) if name == "unif" else 1.0)
        assert x.min() >= mean - half and x.max() < mean + half
    if name == "limit":
        assert set(np.round(x, 12)) == {0.75, 1.25}


def test_a_sample_depends_on_seed_and_index_only():
    a = [Draws(5, 7).draw("agauss", [0.0, 1.0, 1.0]) for _ in range(2)]
    assert a[0] == a[1]
    assert Draws(5, 8).draw("agauss", [0.0, 1.0, 1.0]) != a[0]
    assert Draws(6, 7).draw("agauss", [0.0, 1.0, 1.0]) != a[0]


NETLIST = """mc
.param g={agauss(1k, 100, 1)}
.func rf() {agauss(1k, 100, 1)}
.subckt cell a
.param own={agauss(1k, 100, 1)}
R1 a 0 {own}
.ends
.subckt cell2 a rv={agauss(1k, 100, 1)}
R1 a 0 {rv}
.ends
V1 a 0 1
RG1 a 0 {g}
RG2 a 0 {2*g}
RE1 a 0 {agauss(1k, 100, 1)}
RE2 a 0 {agauss(1k, 100, 1)}
RF1 a 0 {rf()}
RF2 a 0 {rf()}
X1 a cell
X2 a cell
X3 a cell2
X4 a cell2
B1 a 0 I={gauss(1, 0.1, 1) * v(a)}
.op
"""


def test_global_draws_are_shared_and_instance_draws_are_not():
    c = load(NETLIST)
    v = {el.name: el.value for el in c.elements}
    assert v["rg2"] == 2 * v["rg1"]                  # a top-level .param: one draw per sample
    assert v["re1"] != v["re2"]                       # in an element value: each element draws
    assert v["rf1"] != v["rf2"]                       # a .func: each call draws
    assert v["r.x1.r1"] != v["r.x2.r1"]               # a .param inside a subcircuit: per instance
    assert v["r.x3.r1"] != v["r.x4.r1"]               # a subcircuit default: per instance
    b1 = c.element("b1").expr
    assert type(b1.left).__name__ == "Const" and b1.left.value != 1.0  # drawn once, at elaboration
    assert c.draws >= 9 and c.seed == 1 and c.sample == 0


def test_samples_are_reproducible_and_distinct():
    c = load(NETLIST)
    again = load(NETLIST)
    assert [e.value for e in c.elements] == [e.value for e in again.elements]
    s3 = c.variant(sample=3)
    assert [e.value for e in s3.elements] == [e.value for e in c.variant(sample=3).elements]
    assert s3.element("rg1").value != c.element("rg1").value
    assert c.variant(seed=9).element("rg1").value != c.element("rg1").value
    assert c.with_params().element("rg1").value == c.element("rg1").value  # keeps sample and seed


def test_seed_option():
    c = load("t\n.options seed=42\nV1 a 0 1\nR1 a 0 {agauss(1k, 100, 1)}\n.op\n")
    assert c.seed == 42 and c.options.seed == 42
    assert "seed" not in c.options.extra
    d = load("t\n.options seed=random\nV1 a 0 1\nR1 a 0 {agauss(1k, 100, 1)}\n.op\n")
    assert any(f"seed={d.seed}" in n.message for n in d.diagnostics)
    assert load(f"t\n.options seed={d.seed}\nV1 a 0 1\nR1 a 0 {{agauss(1k, 100, 1)}}\n.op\n").element("r1").value \
        == d.element("r1").value


@pytest.mark.parametrize("text, message, column", [
    ("R1 a 0 {agauss(1k, 100, 0)}", r"sigma .* must be positive, got 0", 8),
    ("R1 a 0 {gauss(1k, 0.1, -3)}", r"sigma .* must be positive, got -3", 8),
    ("R1 a 0 {agauss(1k, 100)}", r"agauss\(\) takes 3 arguments, got 2", 9),
    ("R1 a 0 {limit(1k)}", r"limit\(\) takes 2 arguments, got 1", 9),
    ("B1 a 0 I={agauss(v(a), 1, 1)}", r"has no value here", 10),
])
def test_bad_monte_carlo_calls_are_located(text, message, column):
    with pytest.raises(NetlistError) as exc:
        load(f"t\nV1 a 0 1\n{text}\n.op\n")
    assert re.search(message, exc.value.message), exc.value.message
    assert exc.value.location.line == 3 and exc.value.location.column == column, str(exc.value)
    name = re.match(r"\w+", text.split("{")[1]).group() if "{" in text else ""
    if name in RANDOM_FORMS and "has no value" not in message:  # the call as ngspice's manual writes it
        assert RANDOM_FORMS[name] in str(exc.value), str(exc.value)


@pytest.mark.parametrize("option, message", [
    ("seed=-1", "non-negative integer"), ("seed=1.5", "non-negative"), ("seed", "non-negative integer or 'random'"),
    # was rounded through a float (to 1e26 + 21944598528, or to a neighbour of a 17-digit seed)
    ("seed=99999999999999999999999999", r"= 99999999999999999999999999 is beyond the largest seed, 18446744073709551615"),
    ("seed=18446744073709551616", "beyond the largest seed"),
    ("seed=1e17", r"floating point, which holds integers exactly only up to 2\*\*53"),
    ("seed={2**60}", "floating point"),
])
def test_bad_seed_is_located(option, message):
    with pytest.raises(NetlistError, match=message) as exc:
        load(f"t\n.options {option}\nV1 a 0 1\nR1 a 0 1k\n.op\n")
    assert exc.value.location.line == 2
    if "=" in option and option != "seed=-1":  # at the value
        assert exc.value.location.column == len(".options seed=") + 1
        assert "integer from 0 to 18446744073709551615" in exc.value.hint or "digits" in exc.value.hint


def test_an_integer_seed_is_read_exactly():
    text = "t\n.options seed={}\nV1 a 0 1\nR1 a 0 {{agauss(1k, 100, 1)}}\n.op\n"
    assert load(text.format("12345678901234567")).seed == 12345678901234567  # float(...) is ...568
    assert load(text.format("+18446744073709551615")).seed == 2**64 - 1
    assert load(text.format("1e3")).seed == 1000 and load(text.format("{2**53}")).seed == 2**53
    assert load(text.format("12345678901234567")).element("r1").value != \
        load(text.format("12345678901234568")).element("r1").value
    with pytest.raises(NetlistError, match="seed: a seed is an integer from 0 to 18446744073709551615"):
        load(text.format("1")).variant(seed=2**64)


@pytest.mark.ngspice
def test_ngspice_draws_the_same_distributions(tmp_path, ngspice_exe):
    """ngspice's own draws (its generator, our netlist) have the moments netdae's conventions give."""
    count = 400
    forms = {"gauss": ("gauss(1, 0.2, 2)", 1.0, 0.1), "agauss": ("agauss(2, 0.3, 3)", 2.0, 0.1),
             "unif": ("unif(1, 0.3)", 1.0, 0.3 / np.sqrt(3)), "aunif": ("aunif(3, 0.6)", 3.0, 0.6 / np.sqrt(3))}
    lines = ["mc distributions"]
    for key, (expr, _, _) in forms.items():
        lines += [f"V{key}{k} {key}{k} 0 {{{expr}}}\nR{key}{k} {key}{k} 0 1k" for k in range(count)]
    lines += [".op", ".control", "run", "print all", ".endc", ".end"]
    (tmp_path / "mc.cir").write_text("\n".join(lines) + "\n")
    out = subprocess.run([ngspice_exe, "-n", "-b", "mc.cir"], cwd=tmp_path, capture_output=True, text=True,
                         timeout=120).stdout
    values = {m.group(1): float(m.group(2)) for m in re.finditer(r"^\s*([a-z]+\d+) = (\S+)", out, re.M)}
    for key, (_, mean, std) in forms.items():
        x = np.array([values[f"{key}{k}"] for k in range(count)])
        assert x.size == count
        assert abs(x.mean() - mean) < 4.5 * std / np.sqrt(count), key
        assert abs(x.std(ddof=1) - std) < 6 * std / np.sqrt(2 * count), key


def test_the_streams_are_numpys_seed_sequence_bit_for_bit_computed_for_many_keys_at_once():
    """A sweep seeds a thousand samples' streams in one pass (``seed_states``): the same PCG64 states, and so
    the same draws, as numpy's SeedSequence of each key, for keys of every length (a sample's two words, a
    noise source's five, a key whose integers need two words each)."""
    import numpy as np

    from netdae.netlist.montecarlo import Draws, _words, generators, seed_states

    rng = np.random.default_rng(11)
    keys = [tuple(int(v) for v in k) for k in rng.integers(0, 2**32, size=(50, 2))]
    keys += [(0, 0), (0,), (2**32 - 1, 2**32 - 1), (1, 2, 3, 4, 5, 6), (2**40 + 3, 7)]
    keys += [Draws(7, k).source_key(f"v.x{k}.vn") for k in range(20)]
    for key in keys:
        assert np.array_equal(seed_states([_words(key)])[0],
                              np.random.SeedSequence(list(key)).generate_state(4, np.uint64)), key
    made = generators(keys[:30] + keys[-5:])
    for key, g in zip(keys[:30] + keys[-5:], made):
        ref = np.random.Generator(np.random.PCG64(np.random.SeedSequence(list(key))))
        assert np.array_equal(g.standard_normal(4), ref.standard_normal(4))
