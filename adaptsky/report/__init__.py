"""Tables and summaries from run files."""
