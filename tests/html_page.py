"""A page as a browser's tokenizer sees it (:mod:`html.parser`): the oracle of the overview
tests (no comment, processing instruction or declaration but the doctype)."""

from html.parser import HTMLParser


class Page(HTMLParser):
    """The elements (tag, attributes), the text of each, as a browser's tokenizer sees them."""

    def __init__(self, text: str):
        super().__init__(convert_charrefs=True)
        self.elements, self.text, self.open = [], [], []
        self.feed(text)
        self.close()

    def handle_starttag(self, tag, attrs):
        self.elements.append((tag, dict(attrs)))
        if tag not in ("meta", "img"):
            self.open.append(len(self.elements) - 1)
        self.text.append("")

    def handle_endtag(self, tag):
        if self.open:
            self.open.pop()

    def handle_data(self, data):
        if self.open:
            self.text[self.open[-1]] += data

    def handle_comment(self, data):
        raise AssertionError(f"a comment: {data!r}")

    def handle_decl(self, decl):
        assert decl == "doctype html", decl

    def handle_pi(self, data):
        raise AssertionError(f"a processing instruction: {data!r}")

    def unknown_decl(self, data):
        raise AssertionError(f"a declaration: {data!r}")

    def of(self, tag):
        return [(attrs, self.text[i]) for i, (t, attrs) in enumerate(self.elements) if t == tag]
