"""Fixtures of the end-to-end tests."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from adaptsky.experiment.plan import RunSpec


@pytest.fixture(scope="session")
def uninterrupted(tmp_path_factory: pytest.TempPathFactory
                  ) -> list[tuple[RunSpec, dict[str, np.ndarray]]]:
    """The uninterrupted reference of test_reproduce's and test_dask's stopped runs: the two
    runs of ``curves_experiment`` trained once per session, in this process (both tests
    trained the same two runs again). Specs and curves only: nothing to change."""
    from tests.helpers.reproduce import train_uninterrupted

    folder: Path = tmp_path_factory.mktemp("uninterrupted")
    return train_uninterrupted(folder)
