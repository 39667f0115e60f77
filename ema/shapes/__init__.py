"""Mode shapes from poles: LSFD residues, scaling, complexity, mass line, MAC."""
