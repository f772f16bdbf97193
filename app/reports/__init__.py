"""The reports: the command line's and the dashboard's tables, the Markdown tables, the ``--json``
document, a study's output directory and its HTML report, the vehicle's reports."""
