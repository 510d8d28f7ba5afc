"""The oracle: the case and result ``.npz`` interchange format of docs/spec.md, the
contract's tolerances, and the versioned conformance vectors.

- [`pes_ref.oracle.case`][pes_ref.oracle.case]         case validation, running a case, result keys; its .npz files read
  and written by pes_ref.core.runtime.npz, whose refusals become CaseError here
- [`pes_ref.oracle.from_scene`][pes_ref.oracle.from_scene]   a Scene, state and objective as a case
- [`pes_ref.oracle.errors`][pes_ref.oracle.errors]       CaseError (a keyed input error)
- [`pes_ref.oracle.compare`][pes_ref.oracle.compare]      a result against the reference, by the tolerances
- [`pes_ref.oracle.tolerances`][pes_ref.oracle.tolerances]   the tolerances of the contract
- [`pes_ref.oracle.conformance`][pes_ref.oracle.conformance]  the shipped vectors and their generator
"""
from pes_ref.oracle.case import (CASE_KEYS, KEY_GROUPS, OBJECTIVE_PARAMS, OPTIONAL_KEYS, REQUIRED_KEYS,
                                 CaseError, CaseTypeError, ResultExistsError, ValidCase, load_case, read_npz,
                                 result_keys, run_case, run_case_file, save_case, validate_case, write_npz,
                                 write_result)
from pes_ref.oracle.from_scene import case_from_scene

__all__ = [
    "CaseError", "CaseTypeError", "ResultExistsError", "ValidCase",
    "REQUIRED_KEYS", "OPTIONAL_KEYS", "OBJECTIVE_PARAMS", "CASE_KEYS", "KEY_GROUPS",
    "load_case", "validate_case", "run_case", "write_result", "run_case_file", "save_case",
    "read_npz", "write_npz", "result_keys", "case_from_scene",
]
