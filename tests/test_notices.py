"""runtime.notices: the renderer's warnings on stderr, silenced by -q, recorded for a
cluster's client (issue 21, item 7's -q with --cluster)."""

from __future__ import annotations

from runtime import notices


def test_a_recorded_block_keeps_what_is_said_and_says_each_once_thing_again(capsys):
    notices.warn_once("said outside", "f.pov:1:2")
    assert capsys.readouterr().err == "f.pov:1:2: warning: said outside\n"
    for _ in range(2):  # two tasks on one worker: each records its own warnings
        with notices.recorded() as kept:
            notices.warn_once("said outside", "f.pov:1:2")
            notices.warn_once("said outside", "f.pov:1:2")
            notices.warn("plain")
            with notices.silenced():  # a recorded block keeps what a silenced one drops
                notices.say_once("camera line")
        assert kept == ["f.pov:1:2: warning: said outside", "strala: warning: plain",
                        "camera line"]  # fmt: skip
    assert capsys.readouterr().err == ""
    notices.warn_once("said outside", "f.pov:1:2")  # said here once already
    notices.say_once("camera line")  # recorded only: not said here yet
    with notices.silenced():
        notices.warn("dropped")
    assert capsys.readouterr().err == "camera line\n"
