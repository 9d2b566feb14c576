"""Oracle definitions (type + validated parameters) with versions; presets; the
administrator's catalogue of external (command) oracles."""
