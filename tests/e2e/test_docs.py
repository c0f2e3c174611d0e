"""The docs match the code: every scenario and experiment key documented, one way to invoke
commands, Python examples that run, ADAPTSKY_DEBUG and the install options documented."""

import re
from typing import get_args

import pytest
from pydantic import BaseModel

from adaptsky.scenario.models import Scenario
from tests.conftest import ROOT

PAGE = (ROOT / "docs" / "scenario-format.md").read_text()


def _models(annotation: object) -> list[type[BaseModel]]:
    """The models a field holds: its own, or every member's of a tagged union (``[agent]``)."""
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return [annotation]
    return [model for arg in get_args(annotation) for model in _models(arg)]


def _keys(model: type[BaseModel], prefix: str = ""):
    for name, field in model.model_fields.items():
        models = _models(field.annotation)
        if models:
            yield f"[{name}]"
            for member in models:
                yield from _keys(member, f"{name}.")
        else:
            yield name


@pytest.mark.parametrize("key", sorted(set(_keys(Scenario))))
def test_every_scenario_key_is_documented(key):
    assert f"`{key}`" in PAGE or f"## `{key}`" in PAGE


EXPERIMENT_PAGE = (ROOT / "docs" / "reproduce.md").read_text()


def _experiment_keys():
    from adaptsky.experiment.models import Experiment

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


# How commands are invoked: one convention (the activated .venv), stated before the first
# command of every page; the Python examples run as written; ADAPTSKY_DEBUG is documented.
COMMAND_PAGES = ["README.md", "docs/install.md", "docs/environment.md", "docs/training.md",
                 "docs/reproduce.md", "docs/evaluation.md", "docs/plugins.md",
                 "docs/pictures.md"]
COMMAND = re.compile(r"^(adaptsky|python|pip|pytest) ", re.MULTILINE)


def _blocks(text: str, language: str | None = None) -> list[tuple[int, str]]:
    """(offset of the body, body) of every fenced block, or of those in ``language``."""
    fences = list(re.finditer(r"^```(\w*)\n", text, re.MULTILINE))
    blocks = []
    for opening, closing in zip(fences[::2], fences[1::2], strict=False):
        if language is None or opening.group(1) == language:
            blocks.append((opening.end(), text[opening.end():closing.start()]))
    return blocks


@pytest.mark.parametrize("page", COMMAND_PAGES)
def test_the_venv_convention_is_stated_before_a_pages_first_command(page):
    # the docs wrote bare `adaptsky` while README installed into .venv and never activated it
    text = (ROOT / page).read_text()
    offsets = [offset + match.start() for language in ("", "bash", "sh")
               for offset, body in _blocks(text, language) for match in COMMAND.finditer(body)]
    # a page without shell commands: its first Python example needs the environment's python
    offsets = offsets or [offset for offset, _ in _blocks(text, "python")[:1]]
    assert offsets, f"{page}: no command block"
    assert "source .venv/bin/activate" in text[:min(offsets)], page


@pytest.mark.parametrize(("page", "index"), [("README.md", 0), ("docs/environment.md", 0),
                                             ("docs/install.md", 0)])
def test_python_examples_run_as_written(page, index, monkeypatch):
    monkeypatch.chdir(ROOT)
    code = _blocks((ROOT / page).read_text(), "python")[index][1]
    assert "import adaptsky\n" in code or "import adaptsky  #" in code
    namespace: dict[str, object] = {}
    exec(compile(code, f"{page} python block {index}", "exec"), namespace)
    assert namespace["obs"].shape == (17,)


def test_adaptsky_debug_is_documented_and_shows_the_traceback(monkeypatch, capsys):
    from adaptsky.errors import AdaptskyError
    from adaptsky_cli.cli.main import main

    for page in ("README.md", "docs/install.md"):
        assert "ADAPTSKY_DEBUG=1 adaptsky " in (ROOT / page).read_text(), page
    monkeypatch.delenv("ADAPTSKY_DEBUG", raising=False)
    assert main(["plugins", "show", "no-such-model"]) == 1
    assert capsys.readouterr().err.startswith("unknown channel model 'no-such-model'")
    monkeypatch.setenv("ADAPTSKY_DEBUG", "1")
    with pytest.raises(AdaptskyError, match="unknown channel model 'no-such-model'"):
        main(["plugins", "show", "no-such-model"])


def test_install_options_are_documented():
    script = (ROOT / "scripts" / "install.sh").read_text()
    for option in re.findall(r"^\s+(--[a-z-]+)[ )|]", script, re.MULTILINE):
        assert f"`{option}`" in (ROOT / "docs" / "install.md").read_text(), option
        assert option in (ROOT / "README.md").read_text() or option == "--help", option
