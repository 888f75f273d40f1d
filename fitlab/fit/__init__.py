"""Refitting forms to the exact data: targets (what, on which data, measured
how), the optimistix solver with its minimax refinement, metrics, and the
``fitlab refit`` orchestration."""
