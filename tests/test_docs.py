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


EXPERIMENT_PAGE = (ROOT / "docs" / "reproduce.md").read_text()


def _experiment_keys():
    from adaptsky_cli.experiment.models import Experiment

    def walk(model: type[BaseModel]):
        for name, field in model.model_fields.items():
            yield name
            for arg in (field.annotation, *getattr(field.annotation, "__args__", ())):
                for inner in (arg, *getattr(arg, "__args__", ())):
                    if isinstance(inner, type) and issubclass(inner, BaseModel):
                        yield from walk(inner)
    return sorted(set(walk(Experiment)))


@pytest.mark.parametrize("key", _experiment_keys())
def test_every_experiment_key_is_documented(key):
    assert f"\n{key} = " in EXPERIMENT_PAGE or f"[{key}]" in EXPERIMENT_PAGE or \
        f".{key}]" in EXPERIMENT_PAGE or \
        f"[[{key}]]" in EXPERIMENT_PAGE, key
