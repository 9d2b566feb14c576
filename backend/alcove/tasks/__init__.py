"""Task definitions (the user's OCP task) with versions; presets; validation."""
