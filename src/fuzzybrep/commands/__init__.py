"""One module per ``fuzzybrep`` sub-command (see ``fuzzybrep.cli``)."""
