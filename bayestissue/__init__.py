"""bayestissue: Bayesian uncertainty quantification for soft-tissue mechanics.

Nothing runs on import; the sub-packages are imported on demand.
"""

__version__ = "0.1.0"
__all__ = ["__version__"]
