"""Deciding: the pure state machine, a decision written to the rows, a batch iteration's
parallel slots and the owner's running-campaigns limit."""
