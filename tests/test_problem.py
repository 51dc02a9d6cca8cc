"""Core settings types (mmplan.problem): numbers only, nested settings included."""

from __future__ import annotations

import pytest
from pydantic import ValidationError

from mmplan.planners.endogenous.settings import EndogenousSettings
from mmplan.planners.extended_jacobian.settings import ExtendedJacobianSettings


@pytest.mark.parametrize("value", ["0.1", True])
def test_nested_numeric_settings_take_numbers_only(value: object) -> None:
    """A numeric field of a nested settings model rejects a string or a boolean."""
    with pytest.raises(ValidationError, match="expected a number"):
        ExtendedJacobianSettings.model_validate(
            {"method": "extended-jacobian", "virtual_control": {"rho": value}}
        )
    with pytest.raises(ValidationError, match="expected a number"):
        EndogenousSettings.model_validate(
            {"method": "endogenous", "bounds": [{"coordinate": "psi", "min": value, "max": 1}]}
        )


def test_nested_numeric_settings_accept_numbers_and_forbid_unknown_keys() -> None:
    settings = ExtendedJacobianSettings.model_validate(
        {"method": "extended-jacobian", "virtual_control": {"rho": 0.2}}
    )
    assert settings.virtual_control.rho == 0.2
    with pytest.raises(ValidationError, match="extra"):
        ExtendedJacobianSettings.model_validate(
            {"method": "extended-jacobian", "virtual_control": {"rho_typo": 0.2}}
        )
