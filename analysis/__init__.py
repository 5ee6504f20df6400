"""Analysis of thermocue trial logs (filled by issue 5)."""
