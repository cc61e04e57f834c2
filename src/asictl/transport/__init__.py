"""Ways of reaching an AS-i Control master other than the PC2's DPRAM (docs/host.md)."""
