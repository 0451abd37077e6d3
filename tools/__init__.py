"""Developer tools run from a checkout (not shipped in the wheel): the documentation's generated reference."""
