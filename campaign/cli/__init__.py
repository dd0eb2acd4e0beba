"""Subcommands of the ``campaign`` CLI, one module each (see :mod:`campaign.cli.main`)."""
