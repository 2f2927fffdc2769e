"""Configuration: the schema of a configuration file, the scenario built from it, where
named configurations are found, and YAML read with bounds.  Above physics and control
(a stability-tuned drive calls :func:`drill_twin.control.tuning.tune_gains`)."""
