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
           "generator", "generators", "seed_states", "deviate", "random_value"]

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
#: The constants of the seed sequence's hash and mix (M. E. O'Neill's ``seed_seq_fe``, numpy's SeedSequence).
_INIT_A, _MULT_A, _INIT_B, _MULT_B = 0x43B0D7E5, 0x931E8875, 0x8B51F9DD, 0x58F38DED
_MIX_MULT_L, _MIX_MULT_R, _XSHIFT = 0xCA01F9DD, 0x4973F715, 16

#: Tag of the transient noise sources' streams in their keys (so that no key equals a sample's).
_SOURCE_STREAM = 0x7472_6E6F


def _words(key) -> list[int]:
    """The 32-bit entropy words of ``key`` as numpy's SeedSequence reads a list of non-negative integers
    (each integer's words, least significant first; 0 is one word)."""
    out = []
    for k in key:
        k = int(k)
        if k < 0:
            raise ValueError(f"a random stream's key must be non-negative integers, not {k}")
        out.append(k & 0xFFFFFFFF)
        k >>= 32
        while k:
            out.append(k & 0xFFFFFFFF)
            k >>= 32
    return out


def seed_states(words):
    """The PCG64 seeds of many streams at once: numpy's ``SeedSequence(key).generate_state(4, uint64)``.

    Each row of ``words`` is one key's entropy words (:func:`_words`); the arithmetic is the seed
    sequence's (hash each word into a pool of four, mix the pool, mix in the words beyond it, then
    hash the pool out into the state), on all keys at once in uint32 arrays, so that a sweep's
    thousand samples cost one pass instead of a thousand ``SeedSequence`` objects (about 20 us each).

    Parameters
    ----------
    words : array_like of int, shape (m, k)
        Entropy words below 2**32, ``k >= 1``.

    Returns
    -------
    ndarray of uint64, shape (m, 4)

    Examples
    --------
    >>> import numpy as np
    >>> bool(np.all(seed_states([[7, 3]])[0] == np.random.SeedSequence([7, 3]).generate_state(4, np.uint64)))
    True
    """
    import numpy as np

    words = np.asarray(words, dtype=np.uint32)
    m, k = words.shape
    mask = 0xFFFFFFFF
    shift = np.uint32(_XSHIFT)
    hash_const = _INIT_A

    def hashmix(v):
        nonlocal hash_const
        v = v ^ np.uint32(hash_const)
        hash_const = (hash_const * _MULT_A) & mask
        v = v * np.uint32(hash_const)
        return v ^ (v >> shift)

    def mix(x, y):
        r = np.uint32(_MIX_MULT_L) * x - np.uint32(_MIX_MULT_R) * y
        return r ^ (r >> shift)

    with np.errstate(over="ignore"):  # the arithmetic is modulo 2**32
        pool = [hashmix(words[:, i] if i < k else np.zeros(m, dtype=np.uint32)) for i in range(_POOL_WORDS)]
        for src in range(_POOL_WORDS):
            for dst in range(_POOL_WORDS):
                if src != dst:
                    pool[dst] = mix(pool[dst], hashmix(pool[src]))
        for src in range(_POOL_WORDS, k):
            for dst in range(_POOL_WORDS):
                pool[dst] = mix(pool[dst], hashmix(words[:, src]))
        out = np.empty((m, 8), dtype=np.uint32)
        hash_const = _INIT_B
        for i in range(8):
            v = pool[i % _POOL_WORDS] ^ np.uint32(hash_const)
            hash_const = (hash_const * _MULT_B) & mask
            v = v * np.uint32(hash_const)
            out[:, i] = v ^ (v >> shift)
    # the state's 64-bit words are pairs of 32-bit ones, the first the less significant
    return out[:, 0::2].astype(np.uint64) | (out[:, 1::2].astype(np.uint64) << np.uint64(32))


_STATE_CLASS = None


def _seeded(state):
    """numpy's Generator (PCG64) seeded with ``state`` (a row of :func:`seed_states`) as numpy seeds it."""
    global _STATE_CLASS
    import numpy as np

    if _STATE_CLASS is None:
        from numpy.random.bit_generator import ISeedSequence

        class _State(ISeedSequence):  # what PCG64 asks a seed sequence for: the state computed already
            __slots__ = ("state",)

            def __init__(self, state):
                self.state = state

            def generate_state(self, n_words, dtype=np.uint32):
                if n_words != 4 or np.dtype(dtype) != np.uint64:
                    raise ValueError("PCG64 asked for a state netdae did not compute")
                return self.state

        _STATE_CLASS = _State
    return np.random.Generator(np.random.PCG64(_STATE_CLASS(state)))


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
        # an integer takes SeedSequence's quickest path
        entropy = 0
        for w in reversed(words):
            entropy = (entropy << 32) | w
        return np.random.Generator(np.random.PCG64(np.random.SeedSequence(entropy)))
    return np.random.Generator(np.random.PCG64(np.random.SeedSequence(words)))


#: From this many keys on, :func:`generators` seeds them in one pass (:func:`seed_states`); fewer are
#: quicker one SeedSequence each (the pass costs some tens of numpy operations whatever the count).
_BATCH_KEYS = 16


def generators(keys) -> list:
    """:func:`generator` of each key; from :data:`_BATCH_KEYS` keys on, the seeds computed together
    (:func:`seed_states`, one pass for all keys of the same length in words), about 10 us a key
    instead of 20-40.

    Examples
    --------
    >>> keys = [(7, k) for k in range(20)]
    >>> [float(g.standard_normal()) for g in generators(keys)] == [float(generator(k).standard_normal()) for k in keys]
    True
    """
    keys = list(keys)
    if len(keys) < _BATCH_KEYS:
        return [generator(k) for k in keys]
    words = [_words(k) for k in keys]
    out = [None] * len(words)
    for n in sorted({len(w) for w in words}):
        rows = [i for i, w in enumerate(words) if len(w) == n]
        states = seed_states([words[i] for i in rows])
        for i, state in zip(rows, states):
            out[i] = _seeded(state)
    return out


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
