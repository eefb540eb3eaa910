"""The one error of the track package, shared by its modules (rail_mj.track.TrackError)."""


class TrackError(ValueError):
    """A track that cannot be used; the message is one line naming the file and the section."""
