"""Bundled machine descriptions (installed as the data package ncsim.machines)."""
