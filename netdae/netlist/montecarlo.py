"""ngspice's Monte Carlo functions and the random stream of one sample.

The functions (ngspice manual, "Using random param(eters)"), with ``z`` a
standard normal draw and ``u`` uniform on [-1, 1):

=========================  ===========================================
``gauss(nom, rvar, sig)``  ``nom + nom * rvar / sig * z``
``agauss(nom, avar, sig)`` ``nom + avar / sig * z``
``unif(nom, rvar)``        ``nom + nom * rvar * u``
``aunif(nom, avar)``       ``nom + avar * u``
``limit(nom, avar)``       ``nom + avar`` or ``nom - avar``, equally likely
=========================  ===========================================

(``limit`` with three arguments is the clamp ``limit(x, lo, hi)``.)

Where a draw happens decides what varies together, as the ngspice manual
describes it: a top-level ``.param`` is evaluated once per sample, so every
element using it sees the same draw (global variation); a function written
in an element's value, or in a subcircuit's parameters, is evaluated per
instance, so each instance draws its own value (mismatch). ngspice 39 itself
re-draws a top-level ``.param`` at each use (measured); netdae follows the
manual, which is what makes global variation expressible.

Reproducibility: the draws of sample ``k`` come from a stream seeded with
``(seed, k)`` (numpy's ``SeedSequence``), so a sample's values depend on the
seed and its index only, never on which process or in which order samples
are computed. Within a sample, draws are made in elaboration order, which is
fixed by the netlist.

The transient noise sources (``TRNOISE``, ``TRRANDOM``) draw from streams of
their own, one per source, keyed by ``(seed, sample)`` and the source's full
name (:meth:`Draws.source_key`): a source's noise does not change when other
sources or Monte Carlo functions are added, and differs between samples.
"""

from __future__ import annotations

import hashlib
import secrets

__all__ = ["RANDOM_FUNCTIONS", "DEFAULT_SEED", "MAX_SEED", "Draws", "is_random_call", "random_seed", "seed_problem",
           "generator", "deviate", "random_value"]

#: The Monte Carlo functions and their argument counts.
RANDOM_FUNCTIONS: dict[str, int] = {"gauss": 3, "agauss": 3, "unif": 2, "aunif": 2, "limit": 2}

#: Each function as ngspice's manual writes its arguments (shown in errors).
RANDOM_FORMS: dict[str, str] = {"gauss": "gauss(nom, rvar, sigma)", "agauss": "agauss(nom, avar, sigma)",
                                "unif": "unif(nom, rvar)", "aunif": "aunif(nom, avar)", "limit": "limit(nom, avar)"}

#: The seed used when the netlist gives no ``.options seed=`` (ngspice's default rndseed is 1 too).
DEFAULT_SEED = 1
#: The largest seed (an unsigned 64-bit integer), however it is given (``.options seed=``, ``seed=``, ``--seed``).
MAX_SEED = 2**64 - 1


def seed_problem(seed) -> str | None:
    """Why ``seed`` is not a Monte Carlo seed (an integer from 0 to :data:`MAX_SEED`), or None.

    Examples
    --------
    >>> seed_problem(12345678901234567) is None, seed_problem(2**64)
    (True, 'a seed is an integer from 0 to 18446744073709551615, not 18446744073709551616')
    >>> seed_problem(1.0)
    'a seed is an integer from 0 to 18446744073709551615, not 1.0'
    """
    if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed <= MAX_SEED:
        return f"a seed is an integer from 0 to {MAX_SEED}, not {seed!r}"
    return None


def is_random_call(name: str, nargs: int) -> bool:
    """Whether a call ``name(...)`` with ``nargs`` arguments is a Monte Carlo draw.

    Examples
    --------
    >>> is_random_call("agauss", 3), is_random_call("limit", 2), is_random_call("limit", 3)
    (True, True, False)
    """
    arity = RANDOM_FUNCTIONS.get(name)
    return arity is not None and (name != "limit" or nargs == arity)


#: numpy's SeedSequence takes an integer below this as one 32-bit word of entropy.
_WORD = 2**32
#: The words of numpy's SeedSequence pool (its ``pool_size``): entropy that fits is mixed in word by word.
_POOL_WORDS = 4

#: Tag of the transient noise sources' streams in their keys (so that no key equals a sample's).
_SOURCE_STREAM = 0x7472_6E6F


def generator(key):
    """The random generator of the stream ``key`` (numpy's ``SeedSequence`` of it, PCG64).

    Parameters
    ----------
    key : sequence of int
        Non-negative integers: ``(seed, sample)`` for a sample's Monte Carlo
        draws, :meth:`Draws.source_key` for a noise source.

    Examples
    --------
    >>> float(generator((1, 0)).standard_normal()) == float(generator([1, 0]).standard_normal())
    True
    >>> import numpy as np
    >>> ref = np.random.Generator(np.random.PCG64(np.random.SeedSequence([7, 3])))
    >>> float(generator((7, 3)).standard_normal()) == float(ref.standard_normal())
    True
    """
    import numpy as np

    words = [int(k) for k in key]
    if len(words) <= _POOL_WORDS and all(0 <= w < _WORD for w in words):
        # the same entropy as the list, as one integer (its 32-bit words, least significant first): SeedSequence
        # hashes the words missing from its pool as zeros, so dropping trailing zero words changes nothing;
        # an integer takes SeedSequence's quickest path (a sample's stream is made once per row of a sweep)
        entropy = 0
        for w in reversed(words):
            entropy = (entropy << 32) | w
        return np.random.Generator(np.random.PCG64(np.random.SeedSequence(entropy)))
    return np.random.Generator(np.random.PCG64(np.random.SeedSequence(words)))


def random_seed() -> int:
    """A fresh seed from the operating system (``.options seed=random``)."""
    return secrets.randbits(31)


class Draws:
    """The random stream of one sample.

    Parameters
    ----------
    seed : int
        The sweep's (or the netlist's) seed, >= 0.
    sample : int
        The sample index, >= 0.

    Attributes
    ----------
    count : int
        Draws made so far (0: the circuit has no Monte Carlo function).

    Notes
    -----
    The generator is created on the first draw (about 20 us), so a netlist
    without Monte Carlo functions pays nothing.
    """

    __slots__ = ("seed", "sample", "count", "_rng")

    def __init__(self, seed: int, sample: int = 0) -> None:
        self.seed = int(seed)
        self.sample = int(sample)
        self.count = 0
        self._rng = None

    def _generator(self):
        if self._rng is None:
            self._rng = generator((self.seed, self.sample))
        return self._rng

    def source_key(self, name: str) -> tuple[int, ...]:
        """The key of the random stream of the noise source ``name`` in this sample.

        Parameters
        ----------
        name : str
            The source's full lower-case name (``"v1"``, ``"v.x1.vn"``).

        Returns
        -------
        tuple of int
            ``(seed, sample, tag, h)`` with ``h`` a 64-bit hash of the name
            (BLAKE2b: the same in every process, unlike Python's ``hash``).

        Examples
        --------
        >>> d = Draws(7, 3)
        >>> d.source_key("v1") == Draws(7, 3).source_key("v1"), d.source_key("v1") == d.source_key("v2")
        (True, False)
        >>> d.count
        0
        """
        digest = hashlib.blake2b(name.encode("utf-8"), digest_size=8).digest()
        return (self.seed, self.sample, _SOURCE_STREAM, int.from_bytes(digest, "little"))

    def draw(self, name: str, args: list[float]) -> float:
        """One value of the Monte Carlo function ``name`` at ``args``.

        Raises
        ------
        ValueError
            A wrong argument count, or a sigma that is not positive.

        Examples
        --------
        >>> d = Draws(7, 3)
        >>> a = d.draw("agauss", [1.0, 0.1, 1.0]); b = Draws(7, 3).draw("agauss", [1.0, 0.1, 1.0])
        >>> a == b, d.count, d.draw("limit", [1.0, 0.5]) in (0.5, 1.5)
        (True, 1, True)
        """
        arity = RANDOM_FUNCTIONS[name]
        if len(args) != arity:
            raise ValueError(f"{name}() takes {arity} arguments, got {len(args)}: write {RANDOM_FORMS[name]}")
        rng = self._generator()
        self.count += 1
        if arity == 3 and not args[2] > 0.0:
            raise ValueError(f"{name}(): sigma (the third argument) must be positive, got {args[2]:g}: write "
                             f"{RANDOM_FORMS[name]}, the variation being sigma standard deviations "
                             f"(e.g. {name}(1k, {'0.1' if name == 'gauss' else '100'}, 3))")
        return random_value(name, args, deviate(name, rng))


def deviate(name: str, rng) -> float:
    """The one deviate a draw of the Monte Carlo function ``name`` takes from ``rng``: a standard normal
    for ``gauss``/``agauss``, a uniform one in [-1, 1) for ``unif``/``aunif``/``limit``."""
    return float(rng.standard_normal()) if RANDOM_FUNCTIONS[name] == 3 else float(rng.uniform(-1.0, 1.0))


def random_value(name: str, args, d):
    """The value of the Monte Carlo function ``name`` at ``args`` for the deviate ``d`` (:func:`deviate`).

    ngspice's conventions: ``gauss(nom, rvar, sigma)`` and ``agauss(nom, avar, sigma)`` are
    ``nom + (nom rvar or avar) / sigma * d``; ``unif(nom, rvar)`` and ``aunif(nom, avar)``
    ``nom + (nom rvar or avar) * d``; ``limit(nom, avar)`` ``nom + avar`` or ``nom - avar`` by the
    sign of ``d``. ``args`` and ``d`` are floats or arrays over rows (the same IEEE operations).

    Examples
    --------
    >>> random_value("agauss", [1.0, 0.1, 2.0], 1.0), random_value("limit", [1.0, 0.5], -0.3)
    (1.05, 0.5)
    """
    nom, var = args[0], args[1]
    if RANDOM_FUNCTIONS[name] == 3:
        spread = (nom * var if name == "gauss" else var) / args[2]
        return nom + spread * d
    if name == "limit":
        if isinstance(d, float):
            return nom + (var if d >= 0.0 else -var)
        import numpy as np

        return nom + np.where(d >= 0.0, var, -var)
    return nom + (nom * var if name == "unif" else var) * d
