"""Design synthesis: tooth counts from target ratios, shift tables from a mechanism."""
