"""One module per `batlab` sub-command: HELP, add_arguments(parser), run(args)."""
