"""`python -m ncsim` is the `ncsim` command."""
from ncsim.cli.main import main

if __name__ == "__main__":
    main()
