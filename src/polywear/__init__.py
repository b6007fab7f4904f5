"""polywear: friction-induced lateral self-excited vibration of tire tread.

The numeric core is imported on demand; ``import polywear`` stays light.
"""

__version__ = "0.1.0"
