"""Developer tools (evidence scripts); not part of the public API."""
