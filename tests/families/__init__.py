"""One family's tests each: tests/families/<family>/, laid out as harlsync/families/."""
