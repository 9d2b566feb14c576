"""The science layer's bad-input errors: one shape (field, reason, ``field: reason``), kept across
a process boundary (a worker's process pool pickles what a job raised)."""

import pickle

import pytest

from alcove.science.errors import FieldError
from alcove.science.ocp.contact import ContactModelError
from alcove.science.ocp.task_spec import TaskSpecError
from alcove.science.oracles.base import OracleInputError
from alcove.science.oracles.command.spec import CatalogueError
from alcove.science.series import SeriesFormatError
from alcove.science.surrogate.artifact import ArtifactError
from alcove.science.surrogate.config import SurrogateConfigError
from alcove.science.surrogate.dataset import PoolDataError
from alcove.science.surrogate.metrics import MetricInputError


@pytest.mark.parametrize(
    "cls",
    [
        ContactModelError,
        TaskSpecError,
        OracleInputError,
        CatalogueError,
        SeriesFormatError,
        ArtifactError,
        SurrogateConfigError,
        PoolDataError,
        MetricInputError,
    ],
)
def test_each_error_names_its_field_and_survives_pickling(cls: type[FieldError]) -> None:
    err = cls("phases.1.duration", "must be > 0")
    assert isinstance(err, ValueError)
    assert (err.field, err.reason, str(err)) == ("phases.1.duration", "must be > 0", "phases.1.duration: must be > 0")
    back = pickle.loads(pickle.dumps(err))
    assert type(back) is cls
    assert (back.field, back.reason, str(back)) == (err.field, err.reason, str(err))
