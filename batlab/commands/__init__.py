"""One module per `batlab` sub-command: EXAMPLE, add_arguments(parser), run(args).

Each command's one-line help is in ``batlab.cli.COMMANDS`` (listed without importing it).
"""
