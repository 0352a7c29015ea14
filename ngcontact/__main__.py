"""``python -m ngcontact``: the command line interface of ngcontact.cli."""
from ngcontact.cli import main

if __name__ == "__main__":
    main()
