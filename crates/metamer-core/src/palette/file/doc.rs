//! A parsed palette text as the reader ([`super::read`]) walks it: the tree of its top-level keys and
//! `[name]` tables, and its `[[name]]` tables in flat lists.
//!
//! Why this exists: measured on a palette of 1200 designed reflectances (`metamer solve`, whole process,
//! `valgrind --tool=dhat`), the tree the faster paths built was the largest memory reading touched: each
//! `[[colours]]` or `[[reflectances]]` table of three or four keys was a `BTreeMap` leaf of eleven slots
//! (1072 bytes), 5.2 MB for 4800 tables, and the arrays of them grew by copying (another 1.2 MB); the page
//! faults of first touching that memory cost more than building it. The one-pass read ([`super::lines`])
//! and the events' path ([`super::events`]) now put a `[[name]]` table's keys and values in one vector per
//! piece of text ([`Entry`], 96 bytes each) and the table in its list as a range of it ([`Item`]); the
//! `toml` crate's whole parse still gives a tree, which [`Doc::tree`] wraps. The reader sees either through
//! [`TableRef`]; a flat table's keys are searched in order (a palette's tables hold a few), and its unknown
//! keys are reported sorted as the tree's are. Tests turn a flat document back into the tree
//! ([`Doc::into_tree`]) and compare it with the `toml` crate's.

use super::read::{TableExt, Value};
use std::borrow::Cow;
use std::ops::Range;
use toml::Spanned;
use toml::de::{DeTable, DeValue};

/// One `key = value` of a `[[name]]` table read into a flat list.
pub(super) struct Entry<'i> {
    pub(super) key: Spanned<Cow<'i, str>>,
    pub(super) value: Spanned<DeValue<'i>>,
}

/// A `[[name]]` table of a list: its header's span and where its entries sit in [`Doc::entries`].
#[derive(Clone, Debug)]
pub(super) struct Item {
    /// The header's span (`[[name]]`): the `toml` crate's span of the table.
    pub(super) span: Range<usize>,
    /// Which vector of [`Doc::entries`] holds the entries.
    pub(super) piece: u32,
    pub(super) entries: Range<u32>,
}

/// The `[[name]]` tables of one name, in text order.
pub(super) struct List<'i> {
    pub(super) key: Spanned<Cow<'i, str>>,
    /// The first header's span (the `toml` crate's span of the array).
    pub(super) span: Range<usize>,
    pub(super) items: Vec<Item>,
}

/// A parsed text: its tree (top-level keys and `[name]` tables, and any array of tables the `toml` crate's
/// parse built) and the lists of `[[name]]` tables the faster paths read flat (never a key of the tree too).
pub(super) struct Doc<'i> {
    pub(super) root: Spanned<DeTable<'i>>,
    pub(super) lists: Vec<List<'i>>,
    /// The entries of the lists' tables, one vector per piece of text read.
    pub(super) entries: Vec<Vec<Entry<'i>>>,
}

/// A table as the reader reads it: one of the tree's, or a `[[name]]` table's entries.
#[derive(Clone, Copy)]
pub(super) enum TableRef<'a, 'i> {
    Tree(&'a DeTable<'i>),
    Flat(&'a [Entry<'i>]),
}

impl<'a, 'i> TableRef<'a, 'i> {
    /// The value of `key`, with its span.
    pub(super) fn get(self, key: &str) -> Option<&'a Spanned<Value<'i>>> {
        match self {
            TableRef::Tree(t) => t.get(key),
            TableRef::Flat(entries) => entries.iter().find(|e| e.key.get_ref() == key).map(|e| &e.value),
        }
    }

    /// The value of `key`.
    pub(super) fn value(self, key: &str) -> Option<&'a Value<'i>> {
        self.get(key).map(Spanned::get_ref)
    }

    pub(super) fn contains_key(self, key: &str) -> bool {
        self.get(key).is_some()
    }

    /// The keys and values, in no particular order (a tree's sorted, a flat table's as written).
    pub(super) fn iter(self) -> impl Iterator<Item = (&'a str, &'a Spanned<Value<'i>>)> {
        let (tree, flat) = match self {
            TableRef::Tree(t) => (Some(t.iter().map(|(k, v)| (k.get_ref().as_ref(), v))), None),
            TableRef::Flat(entries) => (None, Some(entries.iter().map(|e| (e.key.get_ref().as_ref(), &e.value)))),
        };
        tree.into_iter().flatten().chain(flat.into_iter().flatten())
    }
}

/// The tables of an array of tables: the tree's, or a flat list's.
pub(super) enum Items<'a, 'i> {
    Tree(Vec<&'a DeTable<'i>>),
    Flat(&'a Doc<'i>, &'a [Item]),
}

impl<'a, 'i> Items<'a, 'i> {
    pub(super) fn len(&self) -> usize {
        match self {
            Items::Tree(tables) => tables.len(),
            Items::Flat(_, items) => items.len(),
        }
    }

    /// The `i`th table (`i` below [`Items::len`]).
    pub(super) fn get(&self, i: usize) -> TableRef<'a, 'i> {
        match self {
            Items::Tree(tables) => TableRef::Tree(tables[i]),
            Items::Flat(doc, items) => doc.table(&items[i]),
        }
    }

    pub(super) fn iter(&self) -> impl Iterator<Item = TableRef<'a, 'i>> + '_ {
        (0..self.len()).map(|i| self.get(i))
    }
}

impl<'i> Doc<'i> {
    /// The `toml` crate's tree of a text, as it is.
    pub(super) fn tree(root: Spanned<DeTable<'i>>) -> Doc<'i> {
        Doc { root, lists: Vec::new(), entries: Vec::new() }
    }

    /// No key at all.
    pub(super) fn is_empty(&self) -> bool {
        self.root.get_ref().is_empty() && self.lists.is_empty()
    }

    /// The list of `[[key]]` tables read flat.
    pub(super) fn list(&self, key: &str) -> Option<&List<'i>> {
        self.lists.iter().find(|l| l.key.get_ref() == key)
    }

    /// The top-level keys: the tree's, then the lists'.
    pub(super) fn keys(&self) -> impl Iterator<Item = &str> {
        self.root
            .get_ref()
            .keys()
            .map(|k| k.get_ref().as_ref())
            .chain(self.lists.iter().map(|l| l.key.get_ref().as_ref()))
    }

    /// The value of the top-level `key` in the tree.
    pub(super) fn value(&self, key: &str) -> Option<&Value<'i>> {
        self.root.get_ref().value(key)
    }

    /// The table of a list's item.
    pub(super) fn table(&self, item: &Item) -> TableRef<'_, 'i> {
        TableRef::Flat(&self.entries[item.piece as usize][item.entries.start as usize..item.entries.end as usize])
    }

    /// Every value of the document (the tree's top-level ones and the flat tables').
    pub(super) fn values(&self) -> impl Iterator<Item = &Spanned<Value<'i>>> {
        self.root.get_ref().values().chain(self.entries.iter().flatten().map(|e| &e.value))
    }

    /// The span of a key path such as `colours[3].light` (or of the deepest value on the way that exists).
    pub(super) fn span_of_key(&self, key: &str) -> Option<Range<usize>> {
        /// Where the walk stands.
        enum At<'a, 'i> {
            Root,
            List(&'a List<'i>),
            Flat(TableRef<'a, 'i>),
            Value(&'a Spanned<DeValue<'i>>),
        }
        let mut at = At::Root;
        let mut best = None;
        for segment in key.split('.') {
            let mut parts = segment.split('[');
            let name = parts.next().unwrap_or("");
            let next = match at {
                At::Root => match self.list(name) {
                    Some(list) => At::List(list),
                    None => self.root.get_ref().get(name).map_or(At::Root, At::Value),
                },
                At::List(_) => At::Root,
                At::Flat(t) => t.get(name).map_or(At::Root, At::Value),
                At::Value(v) => v.get_ref().get(name).map_or(At::Root, At::Value),
            };
            match next {
                At::List(list) => best = Some(list.span.clone()),
                At::Value(v) => best = Some(v.span()),
                At::Root | At::Flat(_) => break,
            }
            at = next;
            for index in parts {
                let Ok(i) = index.trim_end_matches(']').parse::<usize>() else { return best };
                at = match at {
                    At::List(list) => match list.items.get(i) {
                        Some(item) => {
                            best = Some(item.span.clone());
                            At::Flat(self.table(item))
                        }
                        None => return best,
                    },
                    At::Value(v) => match v.get_ref().get(i) {
                        Some(v) => {
                            best = Some(v.span());
                            At::Value(v)
                        }
                        None => return best,
                    },
                    At::Root | At::Flat(_) => return best,
                };
            }
        }
        best
    }

    /// The tree this document stands for: the `toml` crate's tree of the same text (the tests compare them).
    #[cfg(test)]
    pub(super) fn into_tree(self) -> Spanned<DeTable<'i>> {
        let span = self.root.span();
        let mut root = self.root.into_inner();
        for list in &self.lists {
            let mut array = toml::de::DeArray::new();
            for item in &list.items {
                let entries =
                    &self.entries[item.piece as usize][item.entries.start as usize..item.entries.end as usize];
                let table: DeTable<'i> = entries.iter().map(|e| (e.key.clone(), e.value.clone())).collect();
                array.push(Spanned::new(item.span.clone(), DeValue::Table(table)));
            }
            root.insert(list.key.clone(), Spanned::new(list.span.clone(), DeValue::Array(array)));
        }
        Spanned::new(span, root)
    }
}
