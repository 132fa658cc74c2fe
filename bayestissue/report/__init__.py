"""REPORT.md rendered from the study's records: a Jinja2 template over typed records, verdicts by named rules.

* :mod:`~bayestissue.report.study` -- the records a report reads (:func:`read_study_records`);
* :mod:`~bayestissue.report.identify`, :mod:`~bayestissue.report.causes` -- the sections' values;
* :mod:`~bayestissue.report.format` -- number formatting (the template's filters);
* :mod:`~bayestissue.report.render` -- the template environment, :func:`render_report`, :func:`write_report`.

Layer: reads records and calls :mod:`bayestissue.analyses.verdicts`; computes nothing of the study itself.
"""

from bayestissue.report.render import render_report, write_report
from bayestissue.report.study import StudyRecords, read_study_records

__all__ = ["StudyRecords", "read_study_records", "render_report", "write_report"]
