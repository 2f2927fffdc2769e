"""Wells: the torque-and-drag statics of a configuration on its well path (``drill-twin
well``), above physics and configuration."""
