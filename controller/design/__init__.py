"""Offline design scripts (scipy, sympy allowed); the running controller never imports them."""
