"""The netlist syntax netdae reads, as data.

One table drives the card parser and its error messages: for every element
letter the expected form(s), the number of nodes, the accepted instance
parameters; for every dot card its form. Elements and dot cards that ngspice
knows and netdae does not implement are listed with a description, so that
the error names what the card is.

Examples
--------
>>> ELEMENTS["c"].forms[0]
'Cname n+ n- value [mname] [ic=v0] [m=mult] [scale=s] [temp=t] [dtemp=dt] [tc1=a] [tc2=b]'
>>> DOT_CARDS[".tran"]
'.tran tstep tstop [tstart [tmax]] [uic]'
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = [
    "ElementSyntax",
    "ELEMENTS",
    "UNSUPPORTED_ELEMENTS",
    "DOT_CARDS",
    "DOT_ALIASES",
    "UNSUPPORTED_DOT_CARDS",
    "IGNORED_DOT_CARDS",
    "SOURCE_FUNCTIONS",
    "supported_letters",
]


@dataclass(frozen=True)
class ElementSyntax:
    """The syntax of one element letter.

    Attributes
    ----------
    letter : str
        Lower-case element letter.
    description : str
        What the element is.
    forms : tuple of str
        The accepted forms, as shown to users.
    keywords : frozenset of str
        Accepted ``name=value`` instance parameters (empty: any, device
        parameters are checked by the device models).
    flags : frozenset of str
        Accepted bare keywords (``off``), stored as ``1.0``.
    """

    letter: str
    description: str
    forms: tuple[str, ...]
    keywords: frozenset = frozenset()
    flags: frozenset = frozenset()

    @property
    def form(self) -> str:
        """The forms joined by ``" | "``."""
        return " | ".join(self.forms)


_RES_KEYS = frozenset({"tc1", "tc2", "tc", "tce", "m", "ac", "temp", "dtemp", "scale", "noisy", "l", "w", "r"})
_CAP_KEYS = frozenset({"ic", "m", "scale", "temp", "dtemp", "tc1", "tc2", "tc", "c", "l", "w"})
_IND_KEYS = frozenset({"ic", "m", "nt", "scale", "temp", "dtemp", "tc1", "tc2", "tc", "l"})

#: Source functions of V and I cards.
SOURCE_FUNCTIONS = "PULSE(v1 v2 td tr tf pw per np) | SIN(vo va freq td theta phase) | " \
    "EXP(v1 v2 td1 tau1 td2 tau2) | PWL(t1 v1 t2 v2 ...) [r=trep] [td=delay] | " \
    "SFFM(vo va fc mdi fs phasec phases) | AM(va vo mf fc td phasec phases) | " \
    "TRNOISE(na nt nalpha namp rtsam rtscapt rtsemt) | TRRANDOM(type ts td param1 param2)"

ELEMENTS: dict[str, ElementSyntax] = {
    s.letter: s
    for s in (
        ElementSyntax("r", "resistor", (
            "Rname n+ n- value [mname] [tc1=a] [tc2=b] [tce=e] [m=mult] [ac=r] [temp=t] [dtemp=dt] "
            "[scale=s] [l=len] [w=width] [noisy=0|1]",), _RES_KEYS),
        ElementSyntax("c", "capacitor", (
            "Cname n+ n- value [mname] [ic=v0] [m=mult] [scale=s] [temp=t] [dtemp=dt] [tc1=a] [tc2=b]",
            "Cname n+ n- Q={charge expression}"), _CAP_KEYS),
        ElementSyntax("l", "inductor", (
            "Lname n+ n- value [mname] [ic=i0] [m=mult] [nt=n] [scale=s] [temp=t] [dtemp=dt] "
            "[tc1=a] [tc2=b]",), _IND_KEYS),
        ElementSyntax("k", "inductor coupling", ("Kname L1 L2 [L3 ...] k",)),
        ElementSyntax("v", "independent voltage source", (
            "Vname n+ n- [[dc] value] [ac mag [phase]] [function]",)),
        ElementSyntax("i", "independent current source", (
            "Iname n+ n- [[dc] value] [ac mag [phase]] [function]",)),
        ElementSyntax("e", "voltage-controlled voltage source", (
            "Ename n+ n- nc+ nc- gain", "Ename n+ n- value={expr}",
            "Ename n+ n- POLY(n) nc1+ nc1- ... ncn+ ncn- c0 c1 ...",
            "Ename n+ n- TABLE {expr} = (x0, y0) (x1, y1) ...",
            "Ename n+ n- LAPLACE {expr} = {H(s)}",
            "Ename out+ out- in+ in- OPAMP")),
        ElementSyntax("g", "voltage-controlled current source", (
            "Gname n+ n- nc+ nc- transconductance", "Gname n+ n- value={expr}",
            "Gname n+ n- POLY(n) nc1+ nc1- ... ncn+ ncn- c0 c1 ...",
            "Gname n+ n- TABLE {expr} = (x0, y0) (x1, y1) ... [m=mult]",
            "Gname n+ n- LAPLACE {expr} = {H(s)}")),
        ElementSyntax("f", "current-controlled current source", (
            "Fname n+ n- vname gain", "Fname n+ n- POLY(n) v1 ... vn c0 c1 ...")),
        ElementSyntax("h", "current-controlled voltage source", (
            "Hname n+ n- vname transresistance", "Hname n+ n- POLY(n) v1 ... vn c0 c1 ...")),
        ElementSyntax("b", "behavioural source", ("Bname n+ n- V={expr}", "Bname n+ n- I={expr}")),
        ElementSyntax("d", "diode", (
            "Dname anode cathode mname [area] [off] [ic=vd] [temp=t] [m=mult] [name=value ...]",),
            flags=frozenset({"off"})),
        ElementSyntax("q", "bipolar transistor", (
            "Qname nc nb ne [ns] mname [area] [off] [ic=vbe,vce] [temp=t] [m=mult] [name=value ...]",
            "Qname nc nb ne ns nt vbic_model [area] [m=mult] [dtemp=dt]  (level=4: the thermal node nt)"),
            flags=frozenset({"off"})),
        ElementSyntax("m", "MOSFET", (
            "Mname nd ng ns nb mname [l=len] [w=width] [ad=a] [as=a] [pd=p] [ps=p] [nrd=n] [nrs=n] "
            "[m=mult] [off] [ic=vds,vgs,vbs] [temp=t] [name=value ...]",
            "Mname nd ng ns vdmos_model [m=mult] [off] [ic=vds,vgs] [temp=t] [dtemp=dt]"),
            flags=frozenset({"off"})),
        ElementSyntax("j", "JFET", (
            "Jname nd ng ns mname [area] [off] [ic=vds,vgs] [temp=t] [dtemp=dt] [m=mult] [name=value ...]",),
            flags=frozenset({"off"})),
        ElementSyntax("z", "MESFET", (
            "Zname nd ng ns mname [area] [off] [ic=vds,vgs] [m=mult]",
            "Zname nd ng ns mesa_model [off] [l=L] [w=W] [m=mult] [ic=vds,vgs] [td=T] [ts=T] [dtemp=dT]"),
            flags=frozenset({"off"})),
        ElementSyntax("s", "voltage-controlled switch", ("Sname n+ n- nc+ nc- mname [on|off]",),
                      flags=frozenset({"on", "off"})),
        ElementSyntax("w", "current-controlled switch", ("Wname n+ n- vname mname [on|off]",),
                      flags=frozenset({"on", "off"})),
        ElementSyntax("t", "lossless transmission line", (
            "Tname p1+ p1- p2+ p2- z0=impedance td=delay [ic=v1,i1,v2,i2]",
            "Tname p1+ p1- p2+ p2- z0=impedance f=frequency [nl=length] [ic=v1,i1,v2,i2]"),
            keywords=frozenset({"z0", "zo", "td", "f", "nl", "ic", "rel", "abs"})),
        ElementSyntax("o", "lossy transmission line (LTRA)", ("Oname p1+ p1- p2+ p2- ltra_model",)),
        ElementSyntax("y", "single lossy transmission line (TXL)", (
            "Yname in ref1 out ref2 txl_model [len=length]",
            "Yname in ref1 out ref2 cpl_model [len=length]  (one conductor of a CPL model)"),
            keywords=frozenset({"len"})),
        ElementSyntax("p", "coupled multiconductor transmission line (CPL)", (
            "Pname in1 ... inN ref1 out1 ... outN ref2 cpl_model [len=length]",),
            keywords=frozenset({"len", "length"})),
        ElementSyntax("u", "uniform distributed RC line (URC)", ("Uname n1 n2 ref urc_model l=length [n=lumps]",),
                      keywords=frozenset({"l", "n"})),
        ElementSyntax("n", "OSDI (compiled Verilog-A) device", (
            "Nname n1 n2 ... mname [name=value ...]",)),
        ElementSyntax("x", "subcircuit instance", ("Xname n1 n2 ... subname [params:] [name=value ...]",)),
    )
}

#: Element letters ngspice knows and netdae does not implement.
UNSUPPORTED_ELEMENTS: dict[str, str] = {
    "a": "XSPICE code model",
}

#: Dot cards netdae reads, with their forms.
DOT_CARDS: dict[str, str] = {
    ".title": ".title text",
    ".param": ".param name=value [name=value ...]",
    ".func": ".func name(arg1, ...) = {expr}",
    ".subckt": ".subckt name node1 ... [params:] [name=default ...]",
    ".ends": ".ends [name]",
    ".model": ".model mname type [(] [name=value ...] [)]",
    ".global": ".global node ...",
    ".include": ".include filename",
    ".osdi": ".osdi filename.osdi (or pre_osdi filename.osdi in a .control block)",
    ".lib": ".lib filename section | .lib section ... .endl",
    ".endl": ".endl [section]",
    ".op": ".op",
    ".dc": ".dc src start stop step [src2 start2 stop2 step2]",
    ".ac": ".ac dec|oct|lin points fstart fstop",
    ".tran": ".tran tstep tstop [tstart [tmax]] [uic]",
    ".pz": ".pz in+ in- out+ out- cur|vol pol|zer|pz",
    ".tf": ".tf v(out[,ref])|i(vsrc) vsrc|isrc",
    ".noise": ".noise v(out[,ref]) vsrc|isrc dec|oct|lin points fstart fstop [pts_per_summary]",
    ".sens": ".sens v(out[,ref])|i(vsrc) [dc] | .sens v(out[,ref])|i(vsrc) ac dec|oct|lin points fstart fstop",
    ".ic": ".ic v(node)=value ...",
    ".nodeset": ".nodeset v(node)=value ...",
    ".options": ".options name[=value] ...",
    ".temp": ".temp t",
    ".save": ".save signal ...",
    ".print": ".print [tran|ac|dc|op] signal ...",
    ".probe": ".probe signal ...",
    ".plot": ".plot [tran|ac|dc|op] signal ...",
    ".four": ".four freq signal [signal ...]  (Fourier analysis of the last period of a .tran)",
    ".meas": ".meas tran|ac|dc name TRIG ... TARG ... | FIND ... | WHEN ... | DERIV ... | "
             "MIN|MAX|PP|AVG|RMS|INTEG sig [FROM=] [TO=] | PARAM='expr'",
    ".step": ".step [lin|dec|oct] [param] name start stop incr|points | .step [param] name list v1 v2 ...",
    ".control": ".control ... .endc (skipped)",
    ".end": ".end",
}

#: Spellings that mean the same dot card.
DOT_ALIASES = {".option": ".options", ".opt": ".options", ".inc": ".include", ".subcircuit": ".subckt",
               ".measure": ".meas", ".fourier": ".four"}

#: Dot cards that only shape ngspice's own output or its control script: read and skipped with a note.
IGNORED_DOT_CARDS: dict[str, str] = {
    ".width": "the width of ngspice's printed output",
    ".csparam": "parameters for ngspice's control script (the circuit does not use them)",
}

#: Dot cards ngspice knows and netdae does not implement.
UNSUPPORTED_DOT_CARDS: dict[str, str] = {
    ".disto": "distortion analysis",
    ".sp": "S-parameter analysis",
    ".pss": "periodic steady-state analysis",
    ".hb": "harmonic-balance analysis",
    ".if": "conditional netlist",
    ".elseif": "conditional netlist",
    ".else": "conditional netlist",
    ".endif": "conditional netlist",
    ".data": "data table",
    ".spiceinit": "ngspice initialisation",
}


def supported_letters() -> str:
    """The element letters netdae reads, e.g. ``"R C L K V I E G F H B D Q M J S W N X"``."""
    return " ".join(letter.upper() for letter in ELEMENTS)
