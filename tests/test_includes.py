""".include and .lib: relative paths, sections, locations, cycles and unreadable files."""

import pytest

import circuitnsds
from circuitnsds.errors import NetlistError
from circuitnsds.netlist import load_netlist, load_netlist_text
from tests.conftest import NETLISTS


def write(path, text: str):
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return path


def keywords(netlist) -> list[str]:
    return [s.keyword for s in netlist.statements]


def test_include_is_relative_to_the_including_file_and_keeps_locations(tmp_path):
    write(tmp_path / "models" / "Diodes.lib", "* diode models\n.model dfast D(Ron=1)\n.inc sub/more.lib\n")
    write(tmp_path / "models" / "sub" / "more.lib", "\n.model dslow D(Ron=2)\n")
    top = write(tmp_path / "top.cir", "title\n.include models/Diodes.lib\nD1 a 0 dfast\n.end\n")
    netlist = load_netlist(top)
    assert keywords(netlist) == [".model", ".model", "d1"]
    first, second, diode = netlist.statements
    assert first.tokens[1] == "dfast" and str(first.location) == f"{tmp_path}/models/Diodes.lib:2"
    assert second.tokens[1] == "dslow" and str(second.location) == f"{tmp_path}/models/sub/more.lib:2"
    assert str(diode.location) == f"{top}:3"
    assert netlist.title == "title" and netlist.ended


def test_quoted_paths_with_spaces_and_case(tmp_path):
    write(tmp_path / "My Models.LIB", ".model dm D\n")
    top = write(tmp_path / "top.cir", "t\n.INCLUDE \"My Models.LIB\"\n.inc 'My Models.LIB'\n")
    assert [s.tokens[1] for s in load_netlist(top).statements] == ["dm", "dm"]


def test_errors_inside_an_included_file_point_into_it(tmp_path):
    write(tmp_path / "bad.lib", "* header\nR1 a 0 -5\n")
    top = write(tmp_path / "top.cir", "t\n.include bad.lib\nV1 a 0 1\n.tran 1m 2m\n.end\n")
    with pytest.raises(NetlistError) as info:
        circuitnsds.read_netlist(top)
    assert str(info.value.where) == f"{tmp_path}/bad.lib:2"
    write(tmp_path / "param.lib", ".param a={b+1}\n")
    top = write(tmp_path / "top2.cir", "t\n.include param.lib\n")
    with pytest.raises(NetlistError, match=r"param.lib:1: parameter 'a': undefined parameter 'b'"):
        load_netlist(top)


LIBRARY = """* a model library with corners
.param shared=1
.lib typ
.param rval=1k
.model dm D(Ron=1)
.lib 'corners.lib' common
.endl typ
.lib fast
.param rval=500
.model dm D(Ron=0.1)
.endl
"""


def test_lib_reads_one_section_only(tmp_path):
    write(tmp_path / "lib" / "models.lib", LIBRARY)
    write(tmp_path / "lib" / "corners.lib", ".lib common\n.param vdd=5\n.endl common\n")
    top = write(tmp_path / "top.cir", "t\n.lib lib/models.lib TYP\nR1 a 0 {rval}\nV1 a 0 {vdd}\n.end\n")
    netlist = load_netlist(top)
    assert [s.tokens for s in netlist.statements] == [
        (".model", "dm", "d", "(", "ron", "=", "1", ")"),
        ("r1", "a", "0", "1000.0"),
        ("v1", "a", "0", "5.0"),
    ]
    fast = write(tmp_path / "fast.cir", "t\n.lib \"lib/models.lib\" fast\nR1 a 0 {rval}\n")
    assert load_netlist(fast).statements[-1].tokens[-1] == "500.0"


def test_sections_in_the_netlist_itself_are_skipped_and_one_argument_lib_includes_a_file(tmp_path):
    write(tmp_path / "vendor.lib", ".model dv D\n")
    top = write(tmp_path / "top.cir", "t\n.lib unused\nR9 a 0 1\n.endl\n.LIB vendor.lib\nD1 a 0 dv\n")
    assert [s.keyword for s in load_netlist(top).statements] == [".model", "d1"]


def test_text_netlists_include_relative_to_the_current_directory(tmp_path, monkeypatch):
    write(tmp_path / "inc.lib", ".model dm D\n")
    monkeypatch.chdir(tmp_path)
    text = "t\n.include inc.lib\nV1 a 0 1\nD1 a b dm\nR1 b 0 1\n.tran 1m 2m\n.end\n"
    circuit = circuitnsds.read_netlist(text)
    assert circuit.element("d1").model.name == "dm"


def test_include_cycles_are_errors_naming_the_chain(tmp_path):
    write(tmp_path / "a.lib", "R1 a 0 1\n.include b.lib\n")
    write(tmp_path / "b.lib", "* b\n.include a.lib\n")
    top = write(tmp_path / "top.cir", "t\n.include a.lib\n")
    with pytest.raises(NetlistError) as info:
        load_netlist(top)
    assert str(info.value.where) == f"{tmp_path}/b.lib:2"
    assert info.value.message == (f".include: {tmp_path}/a.lib includes itself ({top} -> {tmp_path}/a.lib "
                                  f"-> {tmp_path}/b.lib -> {tmp_path}/a.lib)")
    itself = write(tmp_path / "self.cir", "t\n.include self.cir\n")
    with pytest.raises(NetlistError, match=r"self.cir:2: .include: .*self.cir includes itself"):
        load_netlist(itself)
    write(tmp_path / "loop.lib", ".lib s1\n.lib loop.lib s1\n.endl\n")
    top = write(tmp_path / "loop.cir", "t\n.lib loop.lib s1\n")
    with pytest.raises(NetlistError, match=r"loop.lib:2: .lib: .*loop.lib section s1 includes itself"):
        load_netlist(top)


def test_the_same_file_twice_is_not_a_cycle(tmp_path):
    write(tmp_path / "r.lib", ".param k=1\n")
    write(tmp_path / "both.lib",
          ".lib a\n.param x=1\n.endl\n.lib b\n.lib both.lib a\n.param y={x+1}\n.endl\n")
    top = write(tmp_path / "top.cir", "t\n.lib both.lib b\nR1 a 0 {y}\n")
    assert load_netlist(top).statements[0].tokens[-1] == "2.0"


def test_missing_file_names_the_including_line_and_where_it_looked(tmp_path):
    top = write(tmp_path / "top.cir", "t\nR1 a 0 1\n.include models/nothere.lib\n")
    with pytest.raises(NetlistError) as info:
        load_netlist(top)
    assert str(info.value.where) == f"{top}:3"
    assert info.value.message == (f".include: file 'models/nothere.lib' not found "
                                  f"(looked for {tmp_path}/models/nothere.lib)")
    assert "relative to the directory of the file that names them" in info.value.hint
    (tmp_path / "adir").mkdir()
    with pytest.raises(NetlistError, match="file 'adir' is a directory"):
        load_netlist(write(tmp_path / "d.cir", "t\n.inc adir\n"))


def test_missing_section_lists_the_sections(tmp_path):
    write(tmp_path / "models.lib", LIBRARY)
    top = write(tmp_path / "top.cir", "t\n.lib models.lib slow\n")
    with pytest.raises(NetlistError) as info:
        load_netlist(top)
    assert str(info.value.where) == f"{top}:2"
    assert info.value.message == f".lib: section 'slow' not found in {tmp_path}/models.lib"
    assert info.value.hint.startswith("its sections: typ, fast;")
    write(tmp_path / "flat.lib", ".model dm D\n")
    with pytest.raises(NetlistError, match=r"(?s)section 'x' not found.*no .lib NAME ... .endl sections.*"
                       r"write .include FILE"):
        load_netlist(write(tmp_path / "t2.cir", "t\n.lib flat.lib x\n"))
    write(tmp_path / "open.lib", ".lib x\n.model dm D\n")
    with pytest.raises(NetlistError, match=r"open.lib:1: .lib section 'x' has no .endl"):
        load_netlist(write(tmp_path / "t3.cir", "t\n.lib open.lib x\n"))


@pytest.mark.parametrize("line, message", [
    (".include", r"t.cir:2: .include takes one file name, got 0 words"),
    (".include a b", r"t.cir:2: .include takes one file name, got 2 words"),
    (".lib", r"t.cir:2: .lib takes a file and a section name, got 0 words"),
    (".lib a b c", r"t.cir:2: .lib takes a file and a section name, got 3 words"),
    (".endl", r"t.cir:2: .endl without a .lib section to close"),
    ('.include "a.lib', r"t.cir:2: cannot read .*the quote \" is not closed"),
])
def test_malformed_include_lines(tmp_path, line, message):
    with pytest.raises(NetlistError, match=message):
        load_netlist_text(f"t\n{line}\n", file="t.cir", directory=tmp_path)


def test_binary_and_non_utf8_files_are_clear_errors(tmp_path):
    (tmp_path / "blob.lib").write_bytes(b"\x7fELF\x00\x01\x02")
    top = write(tmp_path / "top.cir", "t\n.include blob.lib\n")
    with pytest.raises(NetlistError) as info:
        load_netlist(top)
    assert str(info.value.where) == f"{top}:2"
    assert info.value.message == f"the included file '{tmp_path}/blob.lib' is a binary file, not netlist text"
    (tmp_path / "latin.lib").write_bytes(b"* models\n* \xa9 vendor 1999\n.model dm D\n")
    with pytest.raises(NetlistError) as info:
        load_netlist(write(tmp_path / "l.cir", "t\n.lib latin.lib\n"))
    assert info.value.message == (f"the library '{tmp_path}/latin.lib' is not UTF-8 text "
                                  "(byte 0xa9 on its line 2)")
    assert "iconv -f latin1 -t utf-8 latin.lib" in info.value.hint
    (tmp_path / "top.cir").write_bytes("title\nR1 a 0 1\n".encode("utf-16"))
    with pytest.raises(NetlistError, match="top.cir' is UTF-16 text; circuitnsds reads UTF-8"):
        circuitnsds.read_netlist(tmp_path / "top.cir")


def test_a_utf8_byte_order_mark_is_ignored_and_includes_work_inside_subcircuits(tmp_path):
    (tmp_path / "m.lib").write_bytes("\ufeff.model dm D\n".encode())
    top = write(tmp_path / "top.cir", "title\n.subckt s a\n.include m.lib\nD1 a 0 dm\n.ends\nX1 n s\n")
    assert [s.tokens for s in load_netlist(top).statements] == [
        (".model", "x1.dm", "d"), ("x1.d1", "n", "0", "x1.dm")]


def test_bundled_vendor_library_is_read_through_include():
    netlist = load_netlist(NETLISTS / "vendor_zener_regulator.cir")
    by_name = {s.keyword: s for s in netlist.statements}
    dfwd = next(s for s in netlist.statements if s.is_command and s.tokens[1] == "xz1.dfwd")
    assert str(dfwd.location) == f"{NETLISTS}/vendor_zener.lib:23"
    assert dfwd.tokens[4:] == ("is", "=", "2.61e-15", "n", "=", "1.05", "cjo", "=", "180p", "vj", "=", "0.75",
                               "m", "=", "0.33", "tt", "=", "50.1n", "rs", "=", "0.7", ")")
    assert by_name["xz1.rs"].tokens == ("xz1.rs", "out", "xz1.3", "xz1.rmod", "2.5")
    assert by_name["xz1.e1"].tokens == ("xz1.e1", "xz1.4", "0", "xz1.10", "0", "1")
    assert by_name["v1"].tokens[-3:] == ("20m", "12.0", ")")
