"""Error-state EKF: layout, nominal state, predict/correct/reset, gating, update records."""
