"""Work counts of the BDF integrator on standard circuits, and its benchmark.

The tests bound steps and factorisations at about 1.5 times what was
measured, so a change that makes the integrator work harder fails CI. They
never assert a time. Run the file as a script for the timing benchmark
(per-step time on RC ladders of 3, 1,000 and 100,000 sections)::

    .venv/bin/python tests/test_bdf_perf.py            # all three
    .venv/bin/python tests/test_bdf_perf.py 100000     # one size
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))

from netdae.dae.bdf import integrate  # noqa: E402

from test_bdf_problems import pwl, rc_ladder, rc_lowpass, sine  # noqa: E402

LADDER_SOURCE = dict(amplitude=1.0, freq=1e5)


def _pulse_train(periods=4):
    t, v = [0.0], [0.0]
    for p in range(periods):
        t0 = p * 2.5e-6
        t += [t0 + 1e-6, t0 + 1.01e-6, t0 + 2.01e-6, t0 + 2.02e-6]
        v += [0.0, 1.0, 1.0, 0.0]
    return pwl(t, v)


@pytest.mark.parametrize("relref, max_steps, max_lu", [("local", 600, 75), ("signal", 430, 32)])
def test_ladder_work_counts(relref, max_steps, max_lu):
    # 20 sections, 10 periods of a 100 kHz sine, SPICE tolerances (measured: local 398 steps,
    # 50 factorisations; signal 285 and 21)
    dae = rc_ladder(20, r=1e3, c=1e-9, source=sine(**LADDER_SOURCE))
    res = integrate(dae, (0.0, 1e-4), np.zeros(dae.n), rtol=1e-4, relref=relref)
    st = res.stats
    assert res.ok
    assert st["steps"] < max_steps and st["factorizations"] < max_lu
    assert st["rejected"] < 0.05 * st["steps"] and st["max_order_used"] == 5


def test_pulse_train_work_counts():
    # 16 corners, each a restart: measured 266 steps, 168 factorisations, 24 probes
    dae = rc_lowpass(1e3, 1e-9, _pulse_train())
    res = integrate(dae, (0.0, 1e-5), np.zeros(3), rtol=1e-4)
    st = res.stats
    assert res.ok and st["restarts"] == 16
    assert st["steps"] < 400 and st["factorizations"] < 260 and st["probes"] < 40


def test_large_ladder_stores_only_what_is_saved():
    dae = rc_ladder(20000, r=1e3, c=1e-9, source=sine(**LADDER_SOURCE))
    save = np.array([0, 1, 20000])
    res = integrate(dae, (0.0, 5e-6), np.zeros(dae.n), rtol=1e-4, save=save)
    assert res.ok
    assert res.x.shape == (res.t.size, 3) and res.names == ("v(0)", "v(1)", "v(20000)")
    np.testing.assert_allclose(res.dense(res.t[-1]), res.x[-1], rtol=0, atol=1e-15)
    st = res.stats
    assert st["factorizations"] <= st["cj_changes"] + st["probes"]


# --------------------------------------------------------------------------- benchmark
def _bench(sections, t_end, repeats):
    import tracemalloc

    dae = rc_ladder(sections, r=1e3, c=1e-9, source=sine(**LADDER_SOURCE))
    save = None if sections < 1000 else np.array([0, 1, sections])
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        res = integrate(dae, (0.0, t_end), np.zeros(dae.n), rtol=1e-4, save=save)
        times.append(time.perf_counter() - t0)
    tracemalloc.start()
    integrate(dae, (0.0, t_end), np.zeros(dae.n), rtol=1e-4, save=save)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    st = res.stats
    per_step = np.median(times) / st["steps"]
    print(f"{sections:7d} sections ({dae.n} unknowns): {st['steps']} steps, {st['rejected']} rejected, "
          f"{st['factorizations']} factorisations, median {np.median(times) * 1e3:.1f} ms total, "
          f"{per_step * 1e6:.1f} us/step (fastest run {min(times) / st['steps'] * 1e6:.1f}), "
          f"peak traced memory {peak / 2**20:.1f} MiB")


def main(argv):
    sizes = [int(a) for a in argv] or [3, 1000, 100000]
    for n in sizes:
        t_end = 1e-4 if n <= 1000 else 2e-5
        _bench(n, t_end, repeats=7 if n <= 1000 else 1)


if __name__ == "__main__":
    main(sys.argv[1:])
