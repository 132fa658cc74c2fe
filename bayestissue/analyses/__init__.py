"""The study analyses: what ``make study`` computes on top of the calibration pipeline, and the records it writes.

* :mod:`~bayestissue.analyses.records` -- one typed, versioned record per study stage;
* :mod:`~bayestissue.analyses.verdicts` -- every verdict rule with its named thresholds (the report only calls them);
* :mod:`~bayestissue.analyses.calibration_study` -- the calibration stage's settings and its recovery report;
* :mod:`~bayestissue.analyses.identifiability`, :mod:`~bayestissue.analyses.identifiability_record` -- budgets,
  calibrations, profiles and posterior measures of the identifiability study, and its record;
* :mod:`~bayestissue.analyses.discrepancy` -- T1 vs T2: cross-prediction, the rate study, stereology replicates
  and specimen-level models;
* :mod:`~bayestissue.analyses.controls` -- test pairs from one tissue with each cause planted;
* :mod:`~bayestissue.analyses.scenarios`, :mod:`~bayestissue.analyses.propagate` -- simulated designs and the
  stereological cut posterior;
* :mod:`~bayestissue.analyses.measured` -- the real-data cases and their closed-form check.

Layer: imports the pipeline (:mod:`bayestissue.workflows`) and everything below it; never plotting, report or cli.
"""
