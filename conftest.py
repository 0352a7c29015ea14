"""Run the tutorials at their reduced size under pytest (they read NGCONTACT_QUICK)."""
import os

os.environ.setdefault("NGCONTACT_QUICK", "1")
