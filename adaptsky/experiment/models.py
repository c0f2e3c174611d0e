"""Pydantic models of an experiment file: the runs of one paper experiment, how they are
evaluated, which figure they make and which claims of the paper they are compared with.

The code that runs an experiment knows figure kinds and measured quantities, never an
experiment by name (``docs/reproduce.md`` documents every key).
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field, field_validator, model_validator

from adaptsky.scenario.models import NAME_MAX_LENGTH, Section, safe_name

FigureKind = Literal["learning-curves", "min-se-sweep", "layout-gains", "uav-count",
                     "energy-front", "conditions"]
Baseline = Literal["soa", "tracking", "oracle", "random", "best-response", "oma", "centroid"]
# figure kinds whose evaluated groups are each an x point of their own (their own scenario,
# layouts and baselines) rather than rows over one set of layouts
PER_GROUP_KINDS = ("uav-count", "conditions")
PolicyKind = Literal["last", "best"]

# Quantities each figure kind measures; a claim names one (``vs_<method>`` stands for a
# baseline or another group of the experiment).
QUANTITIES: dict[str, tuple[str, ...]] = {
    "learning-curves": ("sum_rate_bps", "fairness", "gain_vs_soa_pct", "fairness_minus_soa",
                        "pct_of_oracle"),
    "min-se-sweep": ("max_min_se_served", "soa_max_min_se_served"),
    "layout-gains": ("beats_share_pct_vs_*", "mean_gain_pct_vs_*", "median_gain_pct_vs_*",
                     "max_gain_pct_vs_*", "steady_pct_of_oracle"),
    "uav-count": ("sum_rate_bps", "fairness", "pct_of_best_response", "gain_vs_soa_pct",
                  "noma_over_oma_pct"),
    "energy-front": ("sum_rate_bps", "energy_efficiency_bpj", "ee_ratio_vs_unweighted",
                     "sum_rate_pct_of_unweighted", "still_share_pct", "vertical_share_pct"),
    "conditions": ("sum_rate_bps", "fairness", "pct_of_bound", "gain_vs_soa_pct",
                   "gain_vs_tracking_pct", "noma_over_oma_pct", "bound_over_oma_pct",
                   "outage_pct", "least_rate_bps"),
}
# the key an energy-front figure sweeps (its x points are reward weights)
ENERGY_SWEEP_KEY = "reward.w_energy"
# the key a min-se-sweep figure sweeps (its x axis is the required minimum SE)
MIN_SE_SWEEP_KEY = "reward.min_se"


class Sweep(Section):
    """One scenario key swept over values: one run per value and seed (E2's grid)."""

    key: str = Field(min_length=1, max_length=200,
                     description="scenario key, section.key (e.g. reward.min_se)")
    values: list[float | int | bool | str] = Field(min_length=1, description="its values")

    @field_validator("values")
    @classmethod
    def _strings_are_safe(cls, values: list[float | int | bool | str]
                          ) -> list[float | int | bool | str]:
        """A value becomes part of run file names (``<group>-<key>-<value>-seed<n>.h5``)."""
        for value in values:
            if isinstance(value, str):
                safe_name(value)
        return values


class Group(Section):
    """Runs of one agent on one scenario: seeds 0..runs-1, optionally over a sweep."""

    name: str = Field(pattern=r"^[a-z0-9][a-z0-9_-]*$", max_length=NAME_MAX_LENGTH,
                      description="short id, used in file names")
    label: str = Field("", description="name in figures and tables (default: the id)")
    scenario: str = Field(min_length=1, max_length=4096, pattern=r"^[^\x00-\x1f\x7f]*$",
                          description="scenario file, relative to the experiment file")
    runs: int = Field(ge=1, le=1000, description="number of runs: seeds 0 .. runs-1")
    set: list[str] = Field(default_factory=list, description="overrides section.key=value, "
                           "as train --set")
    sweep: Sweep | None = None
    panel: str = Field("", max_length=80, description="the panel of a conditions figure "
                       "that shows this group (groups of one panel side by side)")
    baselines: list[Baseline] | None = Field(None, description="a conditions or uav-count "
                                             "figure: the baselines of this group's point, in "
                                             "place of the evaluation's")
    eval_layouts: int | None = Field(None, ge=1, le=100_000, description="a conditions or "
                                     "uav-count figure: uniform layouts this group and its "
                                     "baselines are evaluated on (from the evaluation's "
                                     "layout_seed), in place of the evaluation's layouts")

    @property
    def title(self) -> str:
        return self.label or self.name


class Evaluation(Section):
    """Greedy rollouts of every run of ``policy`` next to baselines and other groups."""

    policy: str = Field(description="the group whose policies are evaluated")
    layouts: int | None = Field(None, ge=1, description="uniform layouts; none: the "
                                "training layout")
    layout_seed: int = Field(0, ge=0, description="seed of the uniform layouts")
    steps: int = Field(1000, ge=1, description="greedy steps per layout")
    baselines: list[Baseline] = Field(default_factory=lambda: ["soa"],
                                      description="baselines evaluated on the same layouts")
    compare_groups: list[str] = Field(default_factory=list, description="other groups whose "
                                      "policies are evaluated too, paired by seed")
    also: list[str] = Field(default_factory=list, description="other groups measured as the "
                            "policy is (against the baselines, on the same layouts), each in "
                            "rows of its own")
    policies: list[PolicyKind] = Field(default_factory=lambda: ["last"], min_length=1,
                                       description="which weights of each run are evaluated: "
                                       "the last (the paper's), the best kept during training, "
                                       "or both (one row each)")
    served_share: float = Field(0.95, gt=0, le=1, description="a greedy run serves R_min "
                                "when every user meets it in this share of its last 100 steps")

    @field_validator("policies")
    @classmethod
    def _distinct_policies(cls, value: list[str]) -> list[str]:
        if len(set(value)) != len(value):
            raise ValueError(f"policies must be distinct, got {value}")
        return value


class Claim(Section):
    """One row of ``report.md``: a claim of the paper and the quantity that measures it."""

    text: str = Field(min_length=1, description="the claim in words")
    quantity: str = Field(min_length=1, description="a measured quantity (QUANTITIES)")
    paper: float | None = Field(None, description="the paper's number, in the quantity's unit")
    paper_text: str = Field("", description="the paper's number as it states it")


class Figure(Section):
    kind: FigureKind
    title: str = ""
    band: Literal["std", "bootstrap"] = Field("std", description="band over runs: one "
                                              "standard deviation (the paper's) or a 95% "
                                              "bootstrap interval of the mean")


class Experiment(Section):
    id: str = Field(pattern=r"^[a-z0-9][a-z0-9_-]*$", max_length=NAME_MAX_LENGTH,
                    description="short id, e.g. e3")
    title: str = Field(min_length=1)
    paper_figure: str = Field("", description="the paper's figure, e.g. 'Fig. 2'")
    scenario_note: str = Field("", description="which noise setting the figure uses and why")
    groups: list[Group] = Field(min_length=1)
    evaluation: Evaluation
    figure: Figure
    claims: list[Claim] = Field(default_factory=list)

    @model_validator(mode="after")
    def _consistent(self) -> Experiment:
        names = [group.name for group in self.groups]
        if len(set(names)) != len(names):
            raise ValueError(f"group names must be distinct, got {names}")
        spec = self.evaluation
        for name in (spec.policy, *spec.compare_groups, *spec.also):
            if name not in names:
                raise ValueError(f"evaluation names group '{name}'; the groups are "
                                 f"{', '.join(names)}")
        evaluated = [spec.policy, *spec.compare_groups, *spec.also]
        if len(set(evaluated)) != len(evaluated):
            raise ValueError("evaluation: a group is named twice in policy, compare_groups and "
                             f"also ({', '.join(evaluated)})")
        policy = self.group(spec.policy)
        if self.figure.kind == "energy-front" and (
                policy.sweep is None or policy.sweep.key != ENERGY_SWEEP_KEY
                or 0 not in policy.sweep.values):
            raise ValueError(f"an energy-front figure needs the evaluated group "
                             f"'{spec.policy}' swept over {ENERGY_SWEEP_KEY} with 0 among "
                             "the values (the weight every other is compared with)")
        if self.figure.kind == "min-se-sweep" and (
                policy.sweep is None or policy.sweep.key != MIN_SE_SWEEP_KEY):
            raise ValueError(f"a min-se-sweep figure needs the evaluated group "
                             f"'{spec.policy}' swept over {MIN_SE_SWEEP_KEY} (its x axis)")
        if self.figure.kind in PER_GROUP_KINDS:
            swept = [name for name in (spec.policy, *spec.also)
                     if self.group(name).sweep is not None]
            if swept:
                raise ValueError(f"groups.{swept[0]}.sweep: a {self.figure.kind} figure's "
                                 "groups are its x points; give each swept value a group of "
                                 "its own")
        for key in ("eval_layouts", "baselines"):
            own = [group.name for group in self.groups if getattr(group, key) is not None]
            if own and self.figure.kind not in PER_GROUP_KINDS:
                raise ValueError(f"groups.{own[0]}.{key}: a group's own {key} are for "
                                 "conditions and uav-count figures, whose groups are their own "
                                 f"x points, not for a {self.figure.kind} one")
        panelled = [group.name for group in self.groups if group.panel]
        if panelled and self.figure.kind != "conditions":
            raise ValueError(f"groups.{panelled[0]}.panel: panels are drawn in a conditions "
                             f"figure only, not in a {self.figure.kind} one")
        if spec.also and self.figure.kind not in ("layout-gains", *PER_GROUP_KINDS):
            raise ValueError("evaluation.also: other groups are measured in a layout-gains, "
                             "uav-count or conditions figure only, not in a "
                             f"{self.figure.kind} one")
        for claim in self.claims:
            if not quantity_known(claim.quantity, self):
                allowed = ", ".join(QUANTITIES[self.figure.kind])
                raise ValueError(f"claim '{claim.text}': unknown quantity '{claim.quantity}' "
                                 f"for a {self.figure.kind} figure; allowed: {allowed}")
        return self

    @field_validator("groups")
    @classmethod
    def _unique_titles(cls, groups: list[Group]) -> list[Group]:
        """A group's title names its rows in report.md: two groups of one title would share
        them."""
        seen: dict[str, str] = {}
        for group in groups:
            if group.title in seen:
                raise ValueError(f"groups '{seen[group.title]}' and '{group.name}' have the "
                                 f"same label '{group.title}'; give each its own")
            seen[group.title] = group.name
        return groups

    @field_validator("groups")
    @classmethod
    def _one_sweep_key(cls, groups: list[Group]) -> list[Group]:
        keys = {group.sweep.key for group in groups if group.sweep is not None}
        if len(keys) > 1:
            raise ValueError(f"groups sweep different keys {sorted(keys)}; one figure has "
                             "one x axis")
        return groups

    def group(self, name: str) -> Group:
        return next(group for group in self.groups if group.name == name)

    @property
    def methods(self) -> list[str]:
        """What a ``vs_<method>`` quantity may name: baselines and compared groups."""
        return [*self.evaluation.baselines, *self.evaluation.compare_groups]


def quantity_known(quantity: str, experiment: Experiment) -> bool:
    for pattern in QUANTITIES[experiment.figure.kind]:
        if pattern.endswith("*"):
            stem = pattern[:-1]
            if quantity.startswith(stem) and quantity[len(stem):] in experiment.methods:
                return True
        elif quantity == pattern:
            return True
    return False
