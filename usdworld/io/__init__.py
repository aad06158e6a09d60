"""The only code that reads input files; everything it returns is a validated frozen dataclass."""
