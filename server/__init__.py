"""The dashboard server: sources -> hub -> browser, recorder, control API."""
