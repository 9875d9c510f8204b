"""Numeric field types for the file schemas (scenario, sweep, Monte Carlo, vehicle files).

pydantic's lax mode turns a boolean into a number (``True`` → 1.0), and YAML 1.1 reads the bare
words yes/no/on/off/true/false as booleans: ``speed: yes`` or ``mass: on`` flew a 1 m/s mission
or a 1 kg vehicle without a word. :data:`Num` and :data:`Whole` are ``float`` and ``int`` that
refuse a boolean with a message saying why the value is one; text such as ``'1e-3'`` (which
YAML 1.1 reads as a string) still converts as before, and real flag fields stay ``bool``."""

from __future__ import annotations

from typing import Annotated

from pydantic import BeforeValidator

#: Why a bare word came out as a boolean (said wherever a number was expected).
BOOLEAN_WORDS = "YAML reads yes/no/on/off/true/false as booleans"


def boolean_message(v: bool) -> str:
    """``true`` is a boolean (…), not a number: the message for a boolean given as a number."""
    return f"`{str(v).lower()}` is a boolean ({BOOLEAN_WORDS}), not a number"


def not_boolean(v):
    """Before-validator of a numeric field: a boolean is an error, anything else passes on."""
    if isinstance(v, bool):
        raise ValueError(boolean_message(v))
    return v


#: A ``float`` field that refuses booleans.
Num = Annotated[float, BeforeValidator(not_boolean)]
#: An ``int`` field that refuses booleans.
Whole = Annotated[int, BeforeValidator(not_boolean)]
