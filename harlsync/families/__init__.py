"""Controller families, one package each."""
