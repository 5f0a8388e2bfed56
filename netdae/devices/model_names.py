"""What ngspice 39 knows about model cards: parameter names and levels, as data.

ngspice reads a ``.model`` card against the parameter table of the model's
type and level (``dio.c``, ``bjt.c``, ``mos1.c``, ``jfet.c``, ``vdmos.c``, ``sw.c``, ``csw.c``, ``res.c``,
``cap.c``, ``ind.c``); a name that is not in the table is reported ("unrecognized
parameter (x) - ignored") and the model is used without it. netdae does the
same (a located warning, see :func:`netdae.devices.modelcard.ignored_parameters`),
while a name ngspice *uses* and netdae does not implement stays an error:
netdae would otherwise compute something other than ngspice.

Examples
--------
>>> "vceo" in NGSPICE_PARAMETERS["bjt"], "ikf" in NGSPICE_PARAMETERS["diode"]
(False, True)
>>> level_name("mosfet", 49)
'BSIM3'
"""

from __future__ import annotations

__all__ = ["NGSPICE_PARAMETERS", "SENS_MODEL_PARAMETERS", "SENS_AC_ONLY", "SENS_SPELLING",
           "OUTPUT_ONLY", "MODEL_FAMILIES", "LEVEL_TABLES", "table_of", "VECTOR_PARAMETERS", "FLAG_PARAMETERS", "LEVELS", "ADMS_LEVELS", "LEVEL_PARAMETERS", "level_name", "level_words",
           "level_parameters"]


def _names(text: str) -> frozenset:
    return frozenset(text.split())


#: Parameter names of each model family's table in ngspice 39 (``level`` included).
NGSPICE_PARAMETERS: dict[str, frozenset] = {
    "diode": _names(
        "level is js jsw tnom tref rs trs trs1 trs2 n ns tt ttt1 ttt2 cjo cj0 cj vj pb m mj tm1 tm2 cjp cjsw php "
        "mjsw ikf ik ikr nbv area pj tlev tlevc eg xti cta ctc ctp tpb tvj tphp jtun jtunsw ntun xtitun keg kf af "
        "fc fcs bv ibv ib tcv cond isr nr fv_max bv_max id_max te_max pd_max rth0 cth0 lm lp wm wp xom xoi xm xp d"),
    "bjt": _names(
        "level type npn pnp subs tnom tref is ibe ibc bf nf vaf va ikf ik ise c2 ne br nr var vb ikr isc c4 nc rb "
        "irb rbm re rc cje vje pe mje me tf xtf vtf itf ptf cjc vjc pc mjc mc xcjc tr cjs csub ccs vjs ps mjs ms "
        "xtb eg xti fc kf af invearlyvoltf invearlyvoltr invrollofff invrolloffr collectorconduct emitterconduct "
        "transtimevbcfact excessphasefactor iss ns rco vo gamma qco tlev tlevc tbf1 tbf2 tbr1 tbr2 tikf1 tikf2 "
        "tikr1 tikr2 tirb1 tirb2 tnc1 tnc2 tne1 tne2 tnf1 tnf2 tnr1 tnr2 trb1 trb trb2 trc1 trc trc2 tre1 tre tre2 "
        "trm1 trm2 tvaf1 tvaf2 tvar1 tvar2 ctc cte cts tvjc tvje tvjs titf1 titf2 ttf1 ttf2 ttr1 ttr2 tmje1 tmje2 "
        "tmjc1 tmjc2 tmjs1 tmjs2 tns1 tns2 nkf nk tis1 tis2 tise1 tise2 tisc1 tisc2 tiss1 tiss2 quasimod vg cn d "
        "vbe_max vbc_max vce_max pd_max ic_max ib_max te_max rth0"),
    "mosfet": _names(
        "level type vto vt0 kp gamma phi lambda rd rs cbd cbs is pb cgso cgdo cgbo rsh cj mj cjsw mjsw js tox ld "
        "u0 uo fc nmos pmos nsub tpg nss tnom kf af"),
    "jfet": _names(
        "level type njf pjf vt0 vto beta lambda rd gd rs gs cgs cgd pb is fc b tnom tcv vtotc bex betatce xti eg "
        "kf af nlev gdsnoi area"),
    # vdmos.c; 'pchan' and 'nchan' are read by ngspice's reader (inp_vdmos_model), not the table
    "vdmos": _names(
        "vto vth0 kp phi lambda theta rd rs rg tnom kf af vdmosn vdmosp vdmos rq vq mtriode tcvth vtotc mu bex "
        "texp0 texp1 trd1 trd2 trg1 trg2 trs1 trs2 trb1 trb2 subshift ksubthres tksubthres1 tksubthres2 bv ibv nbv "
        "rds rb n tt eg xti is vj cjo m fc cgdmin cgdmax a cgs rthjc rthca cthj vgs_max vgd_max vds_max vgsr_max "
        "vgdr_max pd_max id_max idr_max te_max rth_ext derating pchan nchan"),
    "resistor": _names(
        "rsh narrow dw short dlr tc1 tc1r tc2 tc2r tce defw w l kf af tnom r res bv_max lf wf ef"),
    "capacitor": _names("cap cj cox cjsw capsw defw w defl l narrow short del tc1 tc2 tnom di thick bv_max c"),
    "inductor": _names("ind tc1 tc2 tnom csect dia length nt mu l"),
    "vswitch": _names("sw vt vh ron roff gon goff"),
    "cswitch": _names("csw it ih ron roff gon goff"),
    # ltra.c, txl.c, cpl.c: the lossy lines (netdae.netlist.lossy); 'ltra', 'txl', 'cpl' restate the type
    "ltra": _names("ltra r l g c len rel abs nocontrol steplimit nosteplimit lininterp quadinterp mixedinterp "
                   "truncnr truncdontcut compactrel compactabs"),
    "txl": _names("txl r l g c length"),
    "cpl": _names("cpl r l g c length"),
    # urc.c: the uniform RC line (netdae.netlist.urc); 'urc' restates the type
    "urc": _names("urc k fmax rperl cperl isperl rsperl"),
    # mes.c (level 1, Statz; the levels 2-4, MESA, have tables of their own)
    "mesfet": _names("level type nmf pmf vt0 vto alpha beta lambda b rd gd rs gs cgs cgd pb is fc depl_cap vcrit "
                     "kf af"),
    # mesa.c: the MESA MESFET (Z cards of level 2, 3, 4; :func:`table_of` chooses it by level)
    "mesa": _names("level type nmf pmf vt0 vto lambda lambdahf beta vs rd rs rg ri rf rdi rsi phib phib1 tphib "
                   "astar ggr del xchi tggr n eta m mc alpha sigma0 vsigmat vsigma mu theta mu1 mu2 d nd du ndu th "
                   "ndelta delta tc tvto alphat tlambda teta0 teta1 tmu xtm0 xtm1 xtm2 ks vsg tf flo delfo ag rtc1 "
                   "rtc2 zeta nmax gamma epsi cas cbs gd gs vcrit"),
    # hfet.c: HFET1 (Z cards of nhfet/phfet models, level 5); 'nhfet', 'phfet' restate the type
    "hfet": _names("level type nhfet phfet vt0 vto lambda rd rs rg rdi rsi rgs rgd ri rf eta m mc gamma sigma0 "
                   "vsigmat vsigma mu di delta vs nmax deltad js1d js2d js1s js2s m1d m2d m1s m2s epsi p cm3 a1 a2 "
                   "mv1 kappa delf fgds tf cds phib talpha mt1 mt2 ck1 ck2 cm1 cm2 astar eta1 d1 vt1 eta2 d2 vt2 "
                   "ggr del gatemod klambda kmu kvto"),
    # hfet2.c: HFET2 (level 6)
    "hfet2": _names("level type nhfet phfet cf d1 d2 del delta deltad di epsi eta eta1 eta2 gamma ggr js klambda "
                    "kmu knmax kvto lambda m mc mu n nmax p rd rdi rs rsi sigma0 vs vsigma vsigmat vt0 vt1 vt2 vto"),
}

#: The parameter table of a (family, level) whose table is not its family's (ngspice's MESA for the
#: MESFET levels 2-4).
LEVEL_TABLES: dict[tuple[str, int], str] = {("mesfet", 2): "mesa", ("mesfet", 3): "mesa", ("mesfet", 4): "mesa",
                                            ("hfet", 6): "hfet2"}


def table_of(family: str, level: float) -> str:
    """The name of the parameter table (a key of :data:`NGSPICE_PARAMETERS`) of a family's model level.

    Examples
    --------
    >>> table_of("mesfet", 2.0), table_of("mesfet", 1.0), table_of("bjt", 4.0)
    ('mesa', 'mesfet', 'bjt')
    """
    if level == int(level):
        return LEVEL_TABLES.get((family, int(level)), family)
    return family

#: Names in those tables that are outputs (ngspice reports them, and refuses them on a .model card).
#: The model parameters ngspice 39's sensitivity analysis lists for every instance of a family whatever its
#: model gives (measured; a given parameter is listed too), in ngspice's spelling. ngspice 39 stops with
#: a segmentation fault on a BJT's sensitivity: the BJT's are those an earlier ngspice lists
#: (tests/sensitivity/diffpair.out of its test suite).
SENS_MODEL_PARAMETERS: dict[str, tuple[str, ...]] = {
    "diode": ("af", "area", "bv_max", "cth0", "eg", "fc", "fcs", "fv_max", "ibv", "id_max", "is", "isr", "keg",
              "m", "mjsw", "n", "nbv", "nr", "ns", "ntun", "pd_max", "php", "te_max", "tnom", "vj", "xoi",
              "xom", "xti", "xtitun"),
    "bjt": ("bf", "br", "eg", "fc", "is", "nc", "ne", "nf", "nr", "rb", "rbm", "tnom", "vaf", "xti"),
    "mosfet": ("fc", "is", "kp", "mj", "mjsw", "pb", "phi", "tnom"),
    "jfet": ("af", "b", "beta", "eg", "fc", "gdsnoi", "is", "pb", "tnom", "vt0", "xti"),
}
#: Given model parameters the sensitivity analysis lists in its AC form alone (they enter the charges only).
SENS_AC_ONLY: dict[str, frozenset] = {
    "diode": frozenset({"cjo", "tt", "ttt1", "ttt2"}),
    "bjt": frozenset({"cje", "vje", "mje", "tf", "xtf", "vtf", "itf", "ptf", "cjc", "vjc", "mjc", "xcjc", "tr",
                      "cjs", "vjs", "mjs"}),
    "mosfet": frozenset({"cbd", "cbs", "cgso", "cgdo", "cgbo", "cj", "cjsw"}),
    "jfet": frozenset({"cgs", "cgd"}),
}
#: ngspice's spelling in a sensitivity's name of a parameter netdae's table names otherwise.
SENS_SPELLING: dict[str, dict[str, str]] = {"jfet": {"vto": "vt0"}}

OUTPUT_ONLY: dict[str, frozenset] = {
    "diode": _names("cond"),
    "bjt": _names("type invearlyvoltf invearlyvoltr invrollofff invrolloffr collectorconduct emitterconduct "
                  "transtimevbcfact excessphasefactor"),
    "mosfet": _names("type"),
    "jfet": _names("type gd gs"),
    "vdmos": _names("type"),
    "vswitch": _names("gon goff"),
    "cswitch": _names("gon goff"),
    "mesfet": _names("type gd gs depl_cap vcrit"),
    "mesa": _names("type gd gs vcrit"),
    "hfet": _names("type"),
    "hfet2": _names("type"),
}

#: The model family of each element kind that uses a model card.
MODEL_FAMILIES = {"diode": "diode", "bjt": "bjt", "mosfet": "mosfet", "jfet": "jfet", "vdmos": "vdmos",
                  "mesfet": "mesfet", "hfet": "hfet", "vswitch": "vswitch", "cswitch": "cswitch",
                  "resistor": "resistor", "capacitor": "capacitor", "inductor": "inductor",
                  "ltra": "ltra", "txl": "txl", "cpl": "cpl", "urc": "urc"}

#: Model parameters that are flags (given bare, no value), by model family.
FLAG_PARAMETERS: dict[str, frozenset] = {
    "ltra": _names("ltra nocontrol steplimit nosteplimit lininterp quadinterp mixedinterp truncnr truncdontcut"),
    "txl": _names("txl"),
    "cpl": _names("cpl"),
    "urc": _names("urc"),
}

#: Model parameters ngspice reads as vectors (several numbers after the name), by model type.
VECTOR_PARAMETERS: dict[str, frozenset] = {"cpl": _names("r l g c")}

#: Model levels ngspice 39 knows, with their names (``level=`` on the model card).
LEVELS: dict[str, dict[int, str]] = {
    "diode": {1: "junction diode", 3: "junction diode with geometry"},
    "bjt": {1: "Gummel-Poon", 4: "VBIC", 8: "HICUM/L2", 9: "VBIC"},
    "mosfet": {1: "Shichman-Hodges", 2: "Grove-Frohman", 3: "semi-empirical", 4: "BSIM1", 5: "BSIM2",
               6: "MOS6", 8: "BSIM3", 49: "BSIM3", 9: "MOS9", 10: "B4SOI", 58: "B4SOI", 14: "BSIM4", 54: "BSIM4",
               55: "B3SOI (fully depleted)", 56: "B3SOI (dynamic depletion)", 57: "B3SOI (partially depleted)",
               60: "SOI3", 68: "HiSIM2", 73: "HiSIM_HV"},
    "jfet": {1: "Shichman-Hodges", 2: "Parker-Skellern"},
    "mesfet": {1: "Statz", 2: "MESA", 3: "MESA", 4: "MESA"},
}

#: Levels ngspice's reader gives to models built from Verilog-A by ADMS (``inpdomod.c``: BJT level 6
#: ``bjt504t``, level 7 ``hicum0``), present only in an ngspice configured with ``--enable-adms``:
#: ngspice 39's standard build refuses such a card ("Unable to find definition of given model").
ADMS_LEVELS: dict[str, dict[int, str]] = {
    "bjt": {6: "Mextram 504", 7: "HICUM/L0"},
}

#: The model and instance parameter names (``devhelp``: "in" and "inout") of the
#: ngspice 39 models whose tables differ from their family's level 1, by
#: (family, level); ``level`` (read by ngspice's reader) is among the model names.
LEVEL_PARAMETERS: dict[tuple[str, int], tuple[frozenset, frozenset]] = {
    ("mosfet", 2): (_names(
        "level vto vt0 kp gamma phi lambda rd rs cbd cbs is pb cgso cgdo cgbo rsh cj mj cjsw mjsw js tox ld u0 uo fc "
        "nmos pmos nsub tpg nss delta uexp ucrit vmax xj neff nfs tnom kf af"),
        _names("m l w ad as pd ps nrd nrs off icvds icvgs icvbs temp dtemp ic sens_l sens_w")),
    ("mosfet", 3): (_names(
        "level nmos pmos vto vt0 kp gamma phi rd rs cbd cbs is pb cgso cgdo cgbo rsh cj mj cjsw mjsw js tox ld xl wd "
        "xw delvto delvt0 u0 uo fc nsub tpg nss vmax xj nfs xd alpha eta delta input_delta theta kappa tnom kf af"),
        _names("m l w ad as pd ps nrd nrs off icvds icvgs icvbs ic temp dtemp sens_l sens_w")),
    ("mosfet", 6): (_names(
        "level vto vt0 kv nv kc nc nvth ps gamma gamma1 sigma phi lambda lambda0 lambda1 rd rs cbd cbs is pb cgso "
        "cgdo cgbo rsh cj mj cjsw mjsw js ld tox u0 uo fc nmos pmos tpg nsub nss tnom"),
        _names("l w m ad as pd ps nrd nrs off icvds icvgs icvbs temp dtemp ic sens_l sens_w")),
    ("mosfet", 9): (_names(
        "level nmos pmos vto vt0 kp gamma phi rd rs cbd cbs is pb cgso cgdo cgbo rsh cj mj cjsw mjsw js tox ld xl wd "
        "xw delvto delvt0 u0 uo fc nsub tpg nss vmax xj nfs xd alpha eta delta input_delta theta kappa tnom kf af"),
        _names("m l w ad as pd ps nrd nrs off icvds icvgs icvbs ic temp dtemp sens_l sens_w")),
    ("jfet", 2): (_names(
        "level njf pjf acgam af beta cds cgd cgs delta hfeta hfe1 hfe2 hfg1 hfg2 mvst mxi fc ibd is kf lambda lfgam "
        "lfg1 lfg2 n p vbi pb q rd rs taud taug vbd ver vst vt0 vto xc xi z hfgam tnom"),
        _names("off ic area m icvds icvgs temp dtemp")),
    ("bjt", 4): (_names(
        "level npn pnp tnom tref rcx rci vo gamm hrcf rbx rbi re rs rbp is nf nr fc cbeo cje pe me aje cbco cjc qco "
        "cjep pc mc ajc cjcp ps ms ajs ibei wbe nei iben nen ibci nci ibcn ncn avc1 avc2 isp wsp nfp ibeip ibenp "
        "ibcip ncip ibcnp ncnp vef ver ikf ikr ikp tf qtf xtf vtf itf tr td kfn afn bfn xre xrb xrbi xrc xrci xrs "
        "xvo ea eaie eaic eais eane eanc eans xis xii xin tnf tavc rth cth vrt art ccso qbm nkf xikf xrcx xrbx xrbp "
        "isrr xisr dear eap vbbe nbbe ibbe tvbbe1 tvbbe2 tnbbe ebbe dtemp vers vref vbe_max vbc_max vce_max"),
        _names("area off ic icvbe icvce temp dtemp m")),
    ("mesfet", 1): (NGSPICE_PARAMETERS["mesfet"] - OUTPUT_ONLY["mesfet"],
                    _names("area m off icvds icvgs")),
}
for _level in (2, 3, 4):
    LEVEL_PARAMETERS[("mesfet", _level)] = (NGSPICE_PARAMETERS["mesa"] - OUTPUT_ONLY["mesa"],
                                            _names("l w m off icvds icvgs td ts dtemp"))
LEVEL_PARAMETERS[("hfet", 5)] = (NGSPICE_PARAMETERS["hfet"] - OUTPUT_ONLY["hfet"],
                                 _names("off l w m icvds icvgs ic temp dtemp"))
LEVEL_PARAMETERS[("hfet", 6)] = (NGSPICE_PARAMETERS["hfet2"] - OUTPUT_ONLY["hfet2"],
                                 _names("off l w m icvds icvgs ic temp dtemp"))
#: ngspice 39 reads BJT level 9 as VBIC too (its ``inpdomod.c``; measured: ``showmod`` lists VBIC models).
LEVEL_PARAMETERS[("bjt", 9)] = LEVEL_PARAMETERS[("bjt", 4)]


def level_name(family: str, level: int) -> str | None:
    """ngspice's name of a model level (None: a level ngspice 39 does not know)."""
    return LEVELS.get(family, {}).get(level)


def level_words(family: str, level: float) -> str:
    """What a ``level=`` value is in ngspice, for a refusal: its name, an ADMS model, or unknown.

    Examples
    --------
    >>> level_words("mosfet", 49)
    'BSIM3 in ngspice'
    >>> level_words("bjt", 7)
    "HICUM/L0, ngspice's ADMS model, which ngspice 39 does not include either"
    >>> level_words("bjt", 3)
    'a level ngspice 39 does not know either'
    """
    whole = level == int(level) if level == level and abs(level) != float("inf") else False
    name = level_name(family, int(level)) if whole else None
    if name:
        return f"{name} in ngspice"
    adms = ADMS_LEVELS.get(family, {}).get(int(level)) if whole else None
    if adms:
        return f"{adms}, ngspice's ADMS model, which ngspice 39 does not include either"
    return "a level ngspice 39 does not know either"


def level_parameters(family: str, level: int) -> tuple[frozenset, frozenset] | None:
    """ngspice 39's model and instance parameter names of one model level (None: not tabulated here)."""
    return LEVEL_PARAMETERS.get((family, level))
