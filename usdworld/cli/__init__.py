"""Command-line interface: thin modules over the domain package (which never imports this one)."""
