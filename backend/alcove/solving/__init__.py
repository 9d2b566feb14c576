"""Solving: a campaign iteration's optimal-control problem with the current surrogate as the
contact model, and the stored OCP solutions (primal, dual, trajectory) it warm-starts from."""
