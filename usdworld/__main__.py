"""``python -m usdworld``: the same as the ``usdworld`` command."""

from usdworld.cli.main import run

run()
