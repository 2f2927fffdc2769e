"""Top-drive control on top of the physics and the stability analysis: the
stability-tuned controller (:mod:`.tuning`) and the comparison of the controller modes
(:mod:`.compare`)."""
