"""``python -m fcgen.cli``: the ``fcgen`` command."""

from . import main

if __name__ == "__main__":  # pragma: no cover
    main()
