"""The help style of every ``pycolfrag`` command line (a leaf: it imports nothing of pycolfrag)."""
import argparse


class HelpFormatter(argparse.ArgumentDefaultsHelpFormatter):
    """The help style of the ``pycolfrag`` commands: every option's default shown, except None ones
    (their help text states the default that applies)."""

    def _get_help_string(self, action):
        if action.default is None:
            return action.help
        return super()._get_help_string(action)
