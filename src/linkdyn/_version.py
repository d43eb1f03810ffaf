"""The package's version (its own module, so that a report page can name it without importing
the package's top level, which imports everything)."""

__version__ = "0.1.0"
