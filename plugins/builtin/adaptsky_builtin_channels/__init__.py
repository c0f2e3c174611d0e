"""adaptsky's built-in channel models, registered through entry points like any plugin."""
