"""One module per ``scenweave`` subcommand."""
