"""Developer tools run by ./run: pictures for the documentation."""
