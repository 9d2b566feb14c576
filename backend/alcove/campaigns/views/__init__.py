"""What the UI and the API read: a campaign's detail, lists, metrics, curves and trajectory,
events and live streams, an iteration's picks, the validation suite, the export; and their
routes."""
