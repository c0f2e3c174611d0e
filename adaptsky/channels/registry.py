"""Discovery of channel-model plugins through the entry-point group ``adaptsky.channel_models``.

A plugin is imported when it is used (:func:`plugin`, :func:`get_model_class`: a run imports
the one model its scenario names) or listed (:func:`discover`: every one); naming the installed
models imports none. Each entry point is loaded on its own: one that fails to import, whose
class does not declare what the contract asks (``checker.structural_problems``: a subclass of
ChannelModel with every method, Params with defaults and descriptions, a known contract
version), or whose methods raise or return arrays of the wrong shape, dtype or with NaN in one
call on a few links (``checker.call_problems``), is recorded as broken with its error and fails
only the run that asks for it.
"""

from __future__ import annotations

from dataclasses import dataclass
from difflib import get_close_matches
from functools import cache
from importlib.metadata import EntryPoint, entry_points

from adaptsky.channels.checker import call_problems, structural_problems
from adaptsky.channels.contract import ChannelModel, contract_version_of
from adaptsky.errors import PluginError

ENTRY_POINT_GROUP = "adaptsky.channel_models"


@dataclass(frozen=True)
class PluginInfo:
    """One discovered channel model; ``model`` is None when the plugin is broken."""

    name: str
    package: str
    version: str
    target: str
    model: type[ChannelModel] | None
    error: str = ""

    @property
    def status(self) -> str:
        return "ok" if self.model is not None else "broken"

    @property
    def description(self) -> str:
        return self.model.description if self.model is not None else ""

    @property
    def contract_version(self) -> int | None:
        """The plugin contract the model follows (1 where it declares none); None if broken."""
        return contract_version_of(self.model) if self.model is not None else None

    @property
    def contract_declared(self) -> bool:
        return self.model is not None and self.model.contract_version is not None


def _described(entry_point: EntryPoint) -> dict[str, str]:
    """Name, package, version and target of an entry point (nothing is imported)."""
    dist = entry_point.dist
    return dict(name=entry_point.name, package=dist.name if dist is not None else "?",
                version=dist.version if dist is not None else "?", target=entry_point.value)


def _load(entry_point: EntryPoint) -> PluginInfo:
    info = _described(entry_point)
    try:
        model = entry_point.load()
    except Exception as error:  # any import failure of third-party code
        return PluginInfo(**info, model=None, error=f"{type(error).__name__}: {error}")
    # the cheap part of the contract's checks: the declarations, then one call of each method
    problems = structural_problems(model) or call_problems(model)
    if problems:
        return PluginInfo(**info, model=None, error=f"{entry_point.value}: {problems[0]}"
                          + (f" (and {len(problems) - 1} more: adaptsky plugins check "
                             f"{entry_point.name})" if len(problems) > 1 else ""))
    return PluginInfo(**info, model=model)


def load_class(name: str) -> type[ChannelModel] | object:
    """What the entry point ``name`` names, loaded even when it breaks the contract (for
    ``plugins check``); PluginError if it is unknown or cannot be imported."""
    for entry_point in entry_points(group=ENTRY_POINT_GROUP):
        if entry_point.name == name:
            try:
                return entry_point.load()
            except Exception as error:
                raise PluginError(f"channel model '{name}' cannot be imported: "
                                  f"{type(error).__name__}: {error}") from None
    raise unknown_model(name)


@cache
def _entry_points() -> dict[str, list[EntryPoint]]:
    """Every registered name and its entry points, one per target (the same distribution seen
    twice on sys.path counts once); nothing is imported."""
    found: dict[str, dict[str, EntryPoint]] = {}
    for entry_point in entry_points(group=ENTRY_POINT_GROUP):
        found.setdefault(entry_point.name, {}).setdefault(entry_point.value, entry_point)
    return {name: list(targets.values()) for name, targets in sorted(found.items())}


# the plugins imported (and checked) so far, by name
_loaded: dict[str, PluginInfo] = {}


def names() -> list[str]:
    """The registered channel-model names, sorted, without importing any plugin."""
    return sorted(set(_entry_points()) | set(_loaded))


def plugin(name: str) -> PluginInfo:
    """The channel model registered as ``name``, imported and checked on first use (a name
    registered by two packages is broken); PluginError if no plugin registers it."""
    if name not in _loaded:
        registered = _entry_points().get(name)
        if not registered:
            raise unknown_model(name)
        if len(registered) == 1:
            _loaded[name] = _load(registered[0])
        else:  # broken whatever the classes are: neither is imported
            first, last = _described(registered[0]), _described(registered[-1])
            _loaded[name] = PluginInfo(**last, model=None, error=(
                f"name '{name}' is registered by both {first['package']} and "
                f"{last['package']}"))
    return _loaded[name]


def discover() -> dict[str, PluginInfo]:
    """All registered channel models by name, each imported and checked (``plugins list``)."""
    return {name: plugin(name) for name in names()}


def unknown_model(name: str) -> PluginError:
    """The error for a name no installed plugin registers, naming those that are, and the
    one meant where the name is close to one (a letter or two off, ``mmwave-nyk``)."""
    installed = ", ".join(names()) or "none"
    close = get_close_matches(name, names(), n=1, cutoff=0.75)
    if close:
        return PluginError(f"unknown channel model '{name}'; did you mean '{close[0]}'? "
                           f"(installed: {installed})")
    return PluginError(f"unknown channel model '{name}'; installed: {installed}")


def get_model_class(name: str) -> type[ChannelModel]:
    """The channel-model class registered as ``name``; PluginError if unknown or broken."""
    info = plugin(name)
    if info.model is None:
        raise PluginError(f"channel model '{name}' ({info.package}) is broken: {info.error}")
    return info.model
