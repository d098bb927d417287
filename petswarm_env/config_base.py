"""The base of every config section (:class:`Section`): unknown keys refused, values frozen,
floats finite, no boolean for a number. Its own module so that sections defined outside
:mod:`petswarm_env.config` (:mod:`petswarm_env.robot_types`, :mod:`petswarm_env.config_runtime`) share it without an import circle."""

from __future__ import annotations

import typing
from typing import Annotated, Any

import numpy as np
from pydantic import BaseModel, ConfigDict, ValidationInfo, field_validator
from pydantic_core import PydanticCustomError


def _wants_number_only(annotation: Any) -> bool:
    """Whether a field's type holds numbers (int or float, inside tuples and lists too) and no
    boolean and nothing of any type: a boolean given there is a mistake, not 0 or 1."""
    if annotation is bool or annotation is Any:
        return False
    if annotation in (int, float):
        return True
    args = [a for a in typing.get_args(annotation) if a is not Ellipsis and a is not type(None)]  # Optional[int] too
    if typing.get_origin(annotation) is Annotated:
        args = args[:1]
    return bool(args) and all(_wants_number_only(a) for a in args)


def _holds_bool(value: Any) -> bool:
    if isinstance(value, (list, tuple)):
        return any(_holds_bool(v) for v in value)
    return isinstance(value, (bool, np.bool_))


class Section(BaseModel):
    """A config section: unknown keys are refused, values are frozen once validated. A float
    must be finite (no NaN, no infinity), and a boolean is not a number (pydantic's lax mode
    would read ``true`` as 1)."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    @field_validator("*", mode="before")
    @classmethod
    def _no_bool_for_numbers(cls, value: Any, info: ValidationInfo) -> Any:
        field = cls.model_fields.get(info.field_name or "")
        if field is not None and _holds_bool(value) and _wants_number_only(field.annotation):
            raise PydanticCustomError("bool_not_number", "a boolean is not a number here; give a number")
        return value
