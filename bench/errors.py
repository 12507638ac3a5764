"""The one exception the command line turns into a one-line error and exit status 2.

Each module's own error (a bad suite, an unknown env, a busy folder...) derives from `BadInput`
as well as from the builtin it is, so the CLI can catch them all without importing every
module that defines one: importing the statistics stack only to catch its error cost every
bad-input run seconds before its one line."""


class BadInput(Exception):
    """Input that cannot be used; the message is one line naming the problem."""
