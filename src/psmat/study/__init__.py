"""Studies processed in batch (docs/spec.md §6 study layout, §12): discovery, running, results, simulation."""

from .layout import StudyItem, StudyLayout, Subject, find_study, read_subjects
from .run import RunReport, run_study
from .simulate import simulate_study

__all__ = ["Subject", "StudyItem", "StudyLayout", "find_study", "read_subjects", "RunReport", "run_study",
           "simulate_study"]
