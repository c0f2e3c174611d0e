"""The one place that knows the HDF5 layout of run files (``docs/file-format.md``)."""
