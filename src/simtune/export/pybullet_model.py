"""stub"""


def write(ctx):
    raise NotImplementedError
