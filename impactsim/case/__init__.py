"""The case: a TOML file -> a validated, typed ``Case`` (``schema.py``) in SI units.

``load_case(path, overrides)`` reads a case file, ``load_case_text`` its text, ``case_to_dict``
gives the resolved case back as plain tables; every error is a ``CaseError`` naming the file and
the key.
"""

from impactsim.case.dump import case_to_dict
from impactsim.case.errors import CaseError
from impactsim.case.load import case_from_dict, load_case, load_case_text
from impactsim.case.schema import Case

__all__ = ["Case", "CaseError", "case_from_dict", "case_to_dict", "load_case", "load_case_text"]
