"""The scenario format page documents every key the models accept."""

import pytest
from pydantic import BaseModel

from adaptsky_cli.scenario.models import Scenario
from tests.conftest import ROOT

PAGE = (ROOT / "docs" / "scenario-format.md").read_text()


def _keys(model: type[BaseModel], prefix: str = ""):
    for name, field in model.model_fields.items():
        annotation = field.annotation
        if isinstance(annotation, type) and issubclass(annotation, BaseModel):
            yield f"[{name}]"
            yield from _keys(annotation, f"{name}.")
        else:
            yield name


@pytest.mark.parametrize("key", sorted(set(_keys(Scenario))))
def test_every_scenario_key_is_documented(key):
    assert f"`{key}`" in PAGE or f"## `{key}`" in PAGE
