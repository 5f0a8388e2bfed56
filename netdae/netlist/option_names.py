"""What netdae knows of ngspice 39's ``.options`` names: the warnings of an option netdae does not apply.

Two cases get a warning located at the option (besides the note of every result,
``options not used by netdae``):

* an option that changes what the circuit is in ngspice 39 (:data:`CIRCUIT_OPTIONS`),
  so netdae's results are those of another circuit;
* a name neither netdae nor ngspice 39 knows (:data:`NGSPICE_OPTIONS`): a typo
  (ngspice 39 ignores it without a word), with the nearest known name as a hint.
"""

from __future__ import annotations

import difflib

#: ngspice 39's option names (its manual, chapter "Simulator Variables (.options)", and ``cktsopt.c``; and the
#: variables its ``.four`` reads, which ``.options`` set too: ``nfreqs``, ``fourgridsize``, ``polydegree``).
NGSPICE_OPTIONS = frozenset("""
acct noacct noinit list nomod nopage node opts seed seedinfo temp tnom warn maxwarns savecurrents
abstol gmin gminsteps gminfactor itl1 itl2 keepopinfo noopiter pivrel pivtol reltol rshunt vntol
noopac autostop chgtol convstep convabsstep interp itl3 itl4 itl5 itl6 maxevitr maxevtiter maxopalter
maxord method minbreak ramptime srcsteps trtol xmu badmos3 defad defas defl defw scale wnflag klu
sparse cshunt rseries trytocompact bypass epsmin gshunt indverbosity norefvalue notrnoise filetype
post ingold numdgt measdgt lvltim nfreqs fourgridsize polydegree""".split())

#: Options with which ngspice 39 simulates another circuit, and what they do there.
CIRCUIT_OPTIONS = {
    "ramptime": "ngspice 39 ramps every independent source and the initial conditions from 0 over that time "
                "at the start of a transient",
    "notrnoise": "ngspice 39 switches the transient noise sources (trnoise, trrandom) off",
    "badmos3": "ngspice 39 computes its MOS3 model with the SPICE2 kappa",
    "scale": "ngspice 39 scales every device length and width by it",
}


#: Options of other SPICEs that ngspice 39 ignores, and where ngspice takes what they mean.
OTHER_SPICE_OPTIONS = {
    "maxstep": "the largest time step is the fourth argument of .tran (tmax)",
    "delmax": "the largest time step is the fourth argument of .tran (tmax)",
}


def option_warning(name: str, known: frozenset[str] | set[str]) -> str | None:
    """The warning an option netdae does not apply deserves, or None.

    Parameters
    ----------
    name : str
        The option as written, lower case.
    known : set of str
        The options netdae reads (with those of :data:`NGSPICE_OPTIONS` they are the names
        a typo is compared with).

    Examples
    --------
    >>> option_warning("reltoll", {"reltol"})
    "unknown option 'reltoll' (neither netdae nor ngspice 39 knows it; ngspice 39 ignores it): did you mean 'reltol'?"
    >>> option_warning("trtol", {"reltol"}) is None
    True
    >>> option_warning("maxstep", {"reltol"})
    "option 'maxstep' of other SPICEs is ignored by ngspice 39 and netdae: the largest time step is the fourth argument of .tran (tmax)"
    """
    if name in CIRCUIT_OPTIONS:
        return f"option '{name}' is not applied by netdae: {CIRCUIT_OPTIONS[name]}, so its results are those of " \
               "another circuit"
    if name in NGSPICE_OPTIONS or name in known:
        return None
    if name in OTHER_SPICE_OPTIONS:
        return f"option '{name}' of other SPICEs is ignored by ngspice 39 and netdae: {OTHER_SPICE_OPTIONS[name]}"
    text = f"unknown option '{name}' (neither netdae nor ngspice 39 knows it; ngspice 39 ignores it)"
    close = difflib.get_close_matches(name, sorted(NGSPICE_OPTIONS | set(known)), n=1)
    return text + (f": did you mean '{close[0]}'?" if close else "")
