"""The scenario parser: syntax, time order, errors with line numbers, property tests."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from aamsim import Simulation
from aamsim.errors import ScenarioSyntaxError
from aamsim.stack.parser import Command, format_command, parse_line, parse_scenario, split_commands
from aamsim.stack.tokens import next_arg, split_args

KNOWN = Simulation(use_bluesky_navdata=False).commands


def parse(text):
    return parse_scenario(text, "t.scn", is_command=KNOWN.__contains__)


def test_line_syntax_comments_and_order():
    parsed = parse(
        "# header comment\n"
        "\n"
        "00:00:10.00>ECHO second   # trailing comment\n"
        "00:00:00.00>CRE KL1 EC35 40 -74 90 1500 100\n"
        "0:0:5>kl1 alt 2000\n"
        "00:00:00.00>ECHO a; ECHO b\n"
    )
    assert parsed.errors == []
    assert [(c.time_s, c.command.name) for c in parsed.commands] == [
        (0.0, "CRE"), (0.0, "ECHO"), (0.0, "ECHO"), (5.0, "ALT"), (10.0, "ECHO")]
    # The ACID CMD form becomes CMD ACID; sorting is stable.
    assert parsed.commands[3].command == Command("ALT", "KL1 2000")
    assert parsed.commands[1].command.argtext == "a"
    assert parsed.commands[0].source.line == 4


def test_continuation_lines_and_short_lines():
    parsed = parse("00:00:00.00>ECHO a \\\n  b\n0:0:0>OP\n")
    assert [c.command for c in parsed.commands] == [Command("ECHO", "a b"), Command("OP", "")]


def test_errors_name_the_line_and_token():
    parsed = parse("00:00:00.00>CRE A B\n12:00>ECHO x\nno time stamp\n00:00:01.00>FROB 1\n00:xx:00>OP\n")
    lines = {e.source.line: e.message for e in parsed.errors}
    assert set(lines) == {2, 3, 4, 5}
    assert '"12:00"' in lines[2]
    assert ">" in lines[3]
    assert "FROB" in lines[4]
    assert all(e.source.path == "t.scn" for e in parsed.errors)
    assert len(parsed.commands) == 1


def test_tokenizer_commas_spaces_quotes_and_empty_fields():
    assert split_args("a b,c ,  d") == ["a", "b", "c", "d"]
    assert split_args("a,,c") == ["a", "", "c"]
    assert split_args('"two words" x') == ["two words", "x"]
    assert next_arg("  first, rest of it") == ("first", "rest of it")
    assert split_commands("A 1; B '2;3'; ;C") == ["A 1", "B '2;3'", "C"]


names = st.text(alphabet="ABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_", min_size=1, max_size=10)
# Canonical argument text: stripped, and not starting with the "," that may separate it from the name.
argtexts = st.text(alphabet=st.characters(blacklist_characters="\n\r;#'\"", blacklist_categories=("Cs",)),
                   max_size=40).map(str.strip).filter(lambda s: not s.startswith(","))


@given(names, argtexts)
def test_parse_line_inverts_format(name, argtext):
    cmd = Command(name, argtext)
    assert parse_line(format_command(cmd)) == cmd


@given(st.text(max_size=60))
def test_parse_line_raises_only_syntax_errors(text):
    try:
        cmd = parse_line(text)
    except ScenarioSyntaxError:
        return
    assert cmd.name and cmd.name == cmd.name.upper()


@given(st.lists(st.text(max_size=50), max_size=15))
def test_parse_scenario_never_crashes_and_errors_carry_lines(lines):
    text = "\n".join(lines)
    parsed = parse_scenario(text, "f.scn", is_command=KNOWN.__contains__)
    n = len(text.splitlines())
    for err in parsed.errors:
        assert isinstance(err, ScenarioSyntaxError)
        assert 1 <= err.source.line <= max(n, 1)
        assert str(err).startswith(f"f.scn:{err.source.line}: ")
    times = [c.time_s for c in parsed.commands]
    assert times == sorted(times)


def test_comment_lines_inside_a_continued_command():
    # BlueSky's Sectors/NL/*.scn: comments between the continued lines of a POLYALT.
    text = "00:00:00.00>POLY A 1 1 \\\n   # along the border\n   2 2 \\\n\n   3 1\n00:00:01.00>ECHO next\n"
    parsed = parse_scenario(text)
    assert not parsed.errors
    assert [str(c.command) for c in parsed.commands] == ["POLY A 1 1 2 2 3 1", "ECHO next"]
    assert parsed.commands[0].source.line == 1 and parsed.commands[1].source.line == 6


def test_a_zero_fourth_time_field_is_read_as_bluesky_reads_it():
    # BlueSky's corpus (testscenarios/test_wind.scn) has "0:00:00:00>CRE ..."; BlueSky reads the
    # first three fields. A zero fourth field gives that time under any reading; another one is refused.
    parsed = parse("0:00:00:00>ECHO a\n0:00:01:00>ECHO b\n0:00:01:30>ECHO c\n")
    assert [(c.time_s, c.command.argtext) for c in parsed.commands] == [(0.0, "a"), (1.0, "b")]
    assert len(parsed.errors) == 1 and parsed.errors[0].source.line == 3
    assert 'bad time "0:00:01:30"' in parsed.errors[0].message


def _next_arg_by_characters(text: str) -> tuple[str, str]:
    """The tokenizer's rule read character by character (how it was written before the compiled pattern)."""
    ws = " \t\r\n\f\v"
    i, n = 0, len(text)
    while i < n and text[i] in ws:
        i += 1
    if i < n and text[i] in "'\"":
        end = i + 1
        while end < n and text[end] not in "'\"":
            end += 1
        token, i = text[i + 1:end], min(end + 1, n)
    else:
        start = i
        while i < n and text[i] not in ws and text[i] != ",":
            i += 1
        token = text[start:i]
    while i < n and text[i] in ws:
        i += 1
    if i < n and text[i] == ",":
        i += 1
    while i < n and text[i] in ws:
        i += 1
    return token, text[i:]


@given(st.text(alphabet=st.sampled_from(list(" \t\r\n\f\v,'\"ab1.-\u00a0\u2003;>")), max_size=40))
def test_next_arg_splits_as_the_character_rule_says(text):
    # Separators, both quotes, and Unicode spaces that are not separators (no-break, em space).
    assert next_arg(text) == _next_arg_by_characters(text)


def test_next_arg_quotes_and_empty_fields_by_hand():
    assert next_arg("'a b\" c") == ("a b", "c")  # a quote of either kind ends a quoted token
    assert next_arg('"open to the end') == ("open to the end", "")
    assert next_arg(" , x") == ("", "x")  # an empty field
    assert next_arg("a\u00a0b c") == ("a\u00a0b", "c")  # a no-break space is part of a token
    assert next_arg("ab\"c,d") == ('ab"c', "d")  # a quote inside a token is a character
