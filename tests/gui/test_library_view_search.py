"""The library view of a large library: one page at a time, a search field, paging, one date format."""

from dataclasses import replace

import pytest

from taptune.gui import library_view
from taptune.gui.library_view import LibraryView
from taptune.library import HolderLibrary
from tests.library.entries import make_entry
from tests.library.pg import postgres_server  # noqa: F401  (fixture)


@pytest.fixture
def big(tmp_path, monkeypatch):
    """A database library of 25 holders, shown 10 to a page."""
    monkeypatch.setattr(library_view, "PAGE_SIZE", 10)
    lib = HolderLibrary(tmp_path / "holders.db")
    for i in range(25):
        lib.put(make_entry(f"{'ER32' if i % 2 else 'Shrink'} holder {i:02d}", records=1, first=i))
    return lib


def test_pages_and_search_read_only_what_is_shown(qtbot, big, monkeypatch):
    view = LibraryView(big.path)
    qtbot.addWidget(view)
    assert view.table.rowCount() == 10 and len(view.entries) == 10 and view.total == 25
    assert view.page_label.text() == "1–10 of 25" and not view.previous_button.isEnabled()
    view.next_button.click()
    view.next_button.click()
    assert view.page_label.text() == "21–25 of 25" and not view.next_button.isEnabled()
    assert view.table.item(0, 0).text() == big.names()[20]
    view.search.setText("er32")
    qtbot.waitUntil(lambda: view.total == 12, timeout=2000)  # the search runs after typing stops
    assert view.offset == 0 and all("ER32" in n for n in view.entries)
    view.search.setText("nothing like it")
    view._new_search()
    assert view.table.rowCount() == 0 and "No holder name contains" in view.details.toPlainText()


def test_selecting_a_holder_off_the_page_searches_for_it(qtbot, big):
    view = LibraryView(big.path)
    qtbot.addWidget(view)
    view.select("Shrink holder 24")
    assert view.selected().name == "Shrink holder 24" and view.match == "Shrink holder 24"


def test_one_date_format_in_the_table_and_the_details(qtbot, tmp_path):
    from tests.library.test_database import a_check

    lib = HolderLibrary(tmp_path / "holders.db")
    lib.put(replace(make_entry("A"), checks=(a_check(3, "differs"),)))
    view = LibraryView(lib.path)
    qtbot.addWidget(view)
    assert view.table.item(0, 3).text() == "2026-11-22 12:00"
    assert view.table.item(0, 4).text() == "differs" and view.table.item(0, 4).toolTip().startswith("2026-11-23 08:03")
    details = view.details.toPlainText()
    assert "2026-11-22 12:00: tap0.wav" in details and "2026-11-23 08:03: differs" in details
    assert "T12:00" not in details and ":00Z" not in details


def test_long_names_and_the_last_check_fit_at_1366_px(qtbot, tmp_path):
    lib = HolderLibrary(tmp_path / "holders.db")
    name = "Shrink-fit chuck HSK-A63 Ø12 x 120 reach"
    lib.put(make_entry(name))
    view = LibraryView(lib.path)
    qtbot.addWidget(view)
    view.resize(950, 600)  # the Library tab's share of a 1366 × 768 window
    view.show()
    qtbot.waitExposed(view)
    header = view.table.horizontalHeader()
    widths = [header.sectionSize(c) for c in range(header.count())]
    metrics = view.table.fontMetrics()
    assert widths[0] >= metrics.horizontalAdvance(name)  # the whole name
    assert sum(widths) <= view.table.viewport().width() + 1  # the last column is not cut off


def test_a_server_library_is_shown_without_its_password(qtbot, postgres_server):
    from tests.library.pg import PASSWORD, PASSWORD_ROLE, fresh_database

    url = postgres_server.tcp_url(fresh_database(postgres_server, owner=PASSWORD_ROLE))
    HolderLibrary(url).put(make_entry("on the server"))
    view = LibraryView(url)
    qtbot.addWidget(view)
    assert list(view.entries) == ["on the server"]
    assert PASSWORD not in view.path_label.text() and PASSWORD not in view.location
    assert view.path_label.text().startswith(f"Holder library: postgresql://{PASSWORD_ROLE}:***@127.0.0.1:")
