"""`python -m ncsim` is the `ncsim` command."""
from .cli import main

if __name__ == "__main__":
    main()
