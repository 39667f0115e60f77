"""One module per `batlab` sub-command: EXAMPLE, add_arguments(parser), run(args) (help: batlab.cli)."""
