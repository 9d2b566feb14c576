"""Editor previews run by workers (see :mod:`alcove.previews.service`)."""
