//! Subscribers of any topic behind one type, for the processes that take every topic alike
//! (the logger, the ground link): each sample is handed on as `R`, an enum with a variant per
//! topic of the table (the run log's record).

use crate::{Bus, BusError, SubscriberOptions, TopicSubscriber};
use ipc_types::{Topic, TopicId};

/// A subscriber of some topic whose samples come out as `R`.
pub trait AnySubscriber<R> {
    /// The topic's service name.
    fn topic(&self) -> &'static str;

    /// Takes every pending sample, oldest first, as `R`; the number taken.
    fn drain_as(&self, sink: &mut dyn FnMut(R)) -> Result<usize, BusError>;
}

impl<T: Topic, R: From<T>> AnySubscriber<R> for TopicSubscriber<T> {
    fn topic(&self) -> &'static str {
        T::NAME
    }

    fn drain_as(&self, sink: &mut dyn FnMut(R)) -> Result<usize, BusError> {
        self.drain(|sample| sink(R::from(*sample)))
    }
}

/// Subscribers of a table's worth of topics (see [`Bus::subscribe_each`]).
pub type AnySubscribers<R> = Vec<Box<dyn AnySubscriber<R>>>;

macro_rules! subscribe_each {
    ($($id:ident($ty:ty, $path:literal),)*) => {
        impl Bus {
            /// One subscriber with `options` on every topic of the table that `keep` selects,
            /// in table order.
            pub fn subscribe_each<R>(
                &self,
                options: SubscriberOptions,
                keep: impl Fn(TopicId) -> bool,
            ) -> Result<AnySubscribers<R>, BusError>
            where
                $(R: From<$ty>,)*
            {
                let mut subscribers: AnySubscribers<R> = Vec::new();
                $(
                    if keep(TopicId::$id) {
                        subscribers.push(Box::new(self.subscriber_with::<$ty>(options)?));
                    }
                )*
                Ok(subscribers)
            }
        }
    };
}

ipc_types::for_each_topic!(subscribe_each);
