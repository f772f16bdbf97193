"""The ``tauv`` subcommands, one module each (run, replay, study: ``mc`` and ``reproduce``, serve),
and what they share: the command line's values read into a configuration (values) and the outputs
checked before anything is computed and written atomically (outputs). app.cli builds the parser over
them, derives its flag tables from it and is the entry point: the commands know nothing of argparse
beyond the ``argparse.Namespace`` they are given.
"""
