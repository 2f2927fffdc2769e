"""Rig operations as scenario files: a timeline of set-point segments and events (rotate,
stop the rotary, tag bottom, slack off to a WOB, pick up, wait) run on the digital twin
offline (``drill-twin scenario run``) or by the twin node (parameter ``scenario``)."""
