"""Plotting: functions that take ``ax=None`` (or create their figure) and return it; they never save or show."""

__all__ = []
